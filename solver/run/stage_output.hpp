// One stage's outputs and bookkeeping while it runs: series rows (and the units sidecar), the runaway
// checks at each row, checkpoints, stop requests, the progress line; and the calls of the stage's observers
// (run/stage_observer.hpp: snapshots, the peak contact network, probe points) at each of them.
#pragma once
#include <array>
#include <chrono>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "io/files.hpp"
#include "measure/micro.hpp"
#include "measure/series.hpp"
#include "run/health.hpp"
#include "run/program.hpp"
#include "run/progress.hpp"
#include "run/run_directory.hpp"
#include "run/stage_observer.hpp"

namespace celldem {

class StageOutput {
 public:
  // loading_test: a test (checks kinetic energy), not the preparation. branch: a branch of a test (a rate check's
  // run, a probe, a probe point's rest): a short stage with no checkpoints, run again whole after a stop.
  // `observers` are called in their order (none owned).
  StageOutput(RunDirectory& run, const Deck& deck, const RunOptions& options, const Model& model, std::string stage,
              std::int64_t output_interval, bool loading_test, bool branch, std::vector<StageObserver*> observers);

  // Fresh stage: a new series with its first row. Resumed: the rows up to the checkpoint are kept (a row cut
  // short, or written after the checkpoint, is dropped) and read back, and the energy budget's totals
  // (State::energy) restored from the checkpoint's record.
  void open(State& state, bool resumed);

  // After every step, in two calls with the leg's end decided between them. First the step's row (when due),
  // the observers' on_step and the progress line; a branch throws Interrupted here after a stop request.
  // `contacts`: the state's contacts if the caller has measured them this step (measure_contacts), for the row.
  void record_step(const State& state, double fraction, const std::string& status = "",
                   const ContactMeasures* contacts = nullptr);
  // Then the checkpoint every checkpoint_interval steps, and after a stop request a checkpoint and Interrupted;
  // none at a step where a leg ends (`leg_ends`): a state file holds no per-pair forces, so a stage resumed there
  // would end its leg, or the stage, with no step taken and write its leg-end row, end snapshot and summary from
  // zero forces (and an equilibrium leg would not know it had ended). A stop there waits for the next step, or
  // the next stage's; the stage's end outputs supersede its checkpoints. Returns true when the next step must
  // rebuild the neighbour list: every checkpoint_interval steps, written or not, so that a resumed run does the same.
  bool checkpoint_step(const State& state, bool leg_ends);
  // Whether record_step writes a row at this step.
  bool row_due(const State& state) const { return state.control.stage_steps % output_interval_ == 0; }

  // A leg has ended: its last step becomes a row unless the output interval just wrote one.
  void end_leg(const State& state);
  void finish(const State& state);

  // A warning found while the stage runs: printed and recorded in summary.json (RunDirectory::add_warning),
  // and kept with the stage's checkpoints so that a resumed run records it too.
  void warn(const std::string& warning);

  double elapsed() const;
  const std::filesystem::path& dir() const { return dir_; }
  // Every row of the stage so far, as series.csv holds them.
  const std::vector<SeriesRow>& rows() const { return rows_; }
  // The errors of each leg's controls so far (restored on resume, saved with each checkpoint).
  std::vector<ControlErrors>& control_errors() { return control_errors_; }
  // What the stage started from that a runaway would most likely come from (RunawayMonitor::set_start_cause).
  void set_start_cause(std::string cause) { monitor_.set_start_cause(std::move(cause)); }
  // A leg has ended: whether an observer ends the stage there (StageObserver::on_leg_end; each is asked).
  bool leg_ends_stage(const State& state);

 private:
  void write_row(const State& state, const ContactMeasures* contacts = nullptr);
  std::string continue_command() const;  // what the message of a stop tells the user to run
  void checkpoint(const State& state);
  // The series as a stage resumed from `state` may continue it: the prefix one of its checkpoint's `proofs` proves,
  // up to the checkpoint's step; UsageError naming the file when the series no longer holds that prefix.
  std::string proven_series(const State& state, const nlohmann::json& proofs) const;
  // The record of the stage's checkpoint (written with its state: checkpoint()); UsageError naming the file when it
  // is missing or unreadable.
  nlohmann::json read_checkpoint_record() const;
  void append_series(const std::string& text);
  RunDirectory& run_;
  const Deck& deck_;
  const RunOptions& options_;
  const Model& model_;
  std::string stage_;
  std::filesystem::path dir_;
  std::int64_t output_interval_;
  RunawayMonitor monitor_;
  Progress progress_;
  double elapsed_before_ = 0.0;
  std::chrono::steady_clock::time_point start_;
  AppendFile series_;
  std::uint64_t series_bytes_ = 0, series_hash_ = 0;  // of what series.csv holds (FNV-1a 64, running)
  nlohmann::json last_proof_;  // the last checkpoint's record of the series (null: none yet)
  std::vector<SeriesRow> rows_;
  std::vector<ControlErrors> control_errors_;
  std::vector<std::string> warnings_;  // this stage's own (warn), for the checkpoints
  bool branch_;
  std::vector<StageObserver*> observers_;
};

}  // namespace celldem
