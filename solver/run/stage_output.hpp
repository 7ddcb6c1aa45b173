// One stage's outputs and bookkeeping while it runs: series rows (and the units sidecar), the runaway
// checks at each row, checkpoints, stop requests and the progress line.
#pragma once
#include <chrono>
#include <filesystem>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "io/files.hpp"
#include "measure/series.hpp"
#include "run/health.hpp"
#include "run/program.hpp"
#include "run/progress.hpp"
#include "run/run_directory.hpp"

namespace celldem {

class StageOutput {
 public:
  // loading_test: a test (checks kinetic energy), not the preparation.
  StageOutput(RunDirectory& run, const Deck& deck, const RunOptions& options, const Model& model, std::string stage,
              std::int64_t output_interval, bool loading_test);

  // Fresh stage: a new series with its first row. Resumed: the rows up to the checkpoint are kept (a row cut
  // short, or written after the checkpoint, is dropped) and read back.
  void open(const State& state, bool resumed);

  // After every step. Returns true when the next step must rebuild the neighbour list (after a checkpoint,
  // so that a resumed run does the same). Throws Interrupted after a stop request, once checkpointed.
  bool after_step(const State& state, double fraction, const std::string& status = "");

  void finish(const State& state);

  double elapsed() const;
  const std::filesystem::path& dir() const { return dir_; }
  // Every row of the stage so far, as series.csv holds them.
  const std::vector<SeriesRow>& rows() const { return rows_; }
  // The errors of each leg's controls so far (restored on resume, saved with each checkpoint).
  std::vector<ControlErrors>& control_errors() { return control_errors_; }

 private:
  void write_row(const State& state);
  void checkpoint(const State& state);

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
  std::vector<SeriesRow> rows_;
  std::vector<ControlErrors> control_errors_;
};

}  // namespace celldem
