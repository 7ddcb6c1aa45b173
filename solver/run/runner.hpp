// Runs a deck: prepare a sample (or load one), then each loading test from the same prepared state,
// writing series, state files, checkpoints and summary.json into the run directory.
#pragma once
#include <stdexcept>
#include <string>

#include "core/deck.hpp"
#include "run/progress.hpp"
#include "run/probes.hpp"
#include "run/verify_rate.hpp"

namespace celldem {

struct RunOptions {
  std::string out_dir;
  int threads = 0;        // 0: OpenMP default
  bool force = false;     // overwrite results already in out_dir
  bool resume = false;    // continue an interrupted run in out_dir
  ProgressMode progress = ProgressMode::Off;  // on stderr
  double progress_interval = 30.0;            // [s] between progress lines in a log
  bool quiet = false;     // no stage messages on stdout
  bool fixed_threads = false;  // keep the thread count (no ThreadGovernor trials of one thread)
  VerifyRateOptions verify_rate;  // each test's own convergence check (run/verify_rate.hpp)
  ProbeSelection probes;          // which of the tests' probes this run runs (run/probes.hpp; default all)
  // What the run folder is, as progress.json records it for `merge`: "single", "probe share" (--probes), "seed
  // share" (--seeds k) or "ensemble" (a seed of --seeds k-l); empty: single or probe share, from `probes`.
  std::string kind;
  // With --tolerance: what the rules set and the particle-steps they predict against the deck as written (JSON text,
  // the command line's tolerance_json), written to summary.json's "tolerance"; empty: none.
  std::string tolerance_prediction;
};

// Thrown after SIGINT/SIGTERM once a checkpoint has been written.
struct Interrupted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A run-time failure that is not bad input (numerical trouble, an output that cannot be written).
struct RunError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// A command that cannot go ahead as asked, before any work (an output folder that already holds results):
// a usage error like bad input, not a run-time failure.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

void run_deck(const Deck& deck, const RunOptions& options);

// Installs SIGINT/SIGTERM handlers that ask the running stage to checkpoint and stop.
void install_stop_handlers();
bool stop_requested();

}  // namespace celldem
