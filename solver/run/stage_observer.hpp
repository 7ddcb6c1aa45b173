// What runs beside a stage: its observers. A stage (run/stage_runner.hpp) calls each of its observers, in the list's
// order, at the same few points: when it starts or resumes, after each row and each step, before each checkpoint, at
// each leg's end, when it finishes, and (a loading test) after its summary, when an observer may add its own result.
// A per-test extra (probe points and probes, the rate check, the peak contact network, snapshots) is one observer in
// the list that run/test_observers.hpp builds from the test; the runner itself names none of them.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/deck.hpp"
#include "core/state.hpp"
#include "measure/series.hpp"
#include "run/control_verdict.hpp"

namespace celldem {

class RunDirectory;
struct RunOptions;
struct TestSummary;

// What every stage runs in: the run directory, the deck and the command line's options.
struct RunContext {
  RunDirectory& run;
  const Deck& deck;
  const RunOptions& options;
};

// What a stage leaves, returned whole by run_stage.
struct StageResult {
  std::vector<SeriesRow> rows;                // every row, as series.csv holds them
  std::vector<ControlErrors> control_errors;  // one per leg (restored on a resume)
  double elapsed = 0.0;                       // [s] including the time before a resume
  State state;                                // as the stage ended
  nlohmann::json network_time_step;           // the time step against the contact network (run/time_step_check)
};

// A finished loading test, as its observers see it after its summary is written.
struct FinishedTest {
  const TestDef& test;
  const StageResult& stage;
  const TestSummary& summary;
};

// What an observer adds to its test's summary: summary.json's tests.<test>.<key>, warnings for the run, and lines
// for the console once the test is done (each printed after "<test>: ").
struct ObserverReport {
  std::string key;
  nlohmann::json value;
  std::vector<std::string> warnings;
  std::vector<std::string> console;
};

class StageObserver {
 public:
  virtual ~StageObserver() = default;
  // A fresh stage once its first row is written (on_row has seen it).
  virtual void on_start(const State&) {}
  // A resumed stage: its checkpoint's state and the rows read back (no on_row for them).
  virtual void on_resume(const State&, const std::vector<SeriesRow>&) {}
  // After each row is written (the row as series.csv prints it).
  virtual void on_row(const State&, const SeriesRow&) {}
  // After each step (and its row, if it wrote one).
  virtual void on_step(const State&) {}
  // Just before each checkpoint is written: what a resume needs must be on disk by then.
  virtual void on_checkpoint(const State&) {}
  // What the observer must remember across a resume, written into the checkpoint's record (memory.<its key>) by
  // the same rename as the state, and handed back to restore() before on_resume.
  virtual void save(nlohmann::json& /*memory*/) const {}
  virtual void restore(const nlohmann::json& /*memory*/) {}
  // At each leg's end, the last leg's included: true ends the stage there.
  virtual bool on_leg_end(const State&) { return false; }
  // The stage's last row is written: its state and every row.
  virtual void on_finish(const State&, const std::vector<SeriesRow>&) {}
  // A loading test's summary is written: the observer's result for it, if it has one.
  virtual std::optional<ObserverReport> after_test(const FinishedTest&) { return std::nullopt; }
};

}  // namespace celldem
