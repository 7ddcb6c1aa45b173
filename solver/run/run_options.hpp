// What the command line asks of a run (celldem run's options), beside the deck.
#pragma once
#include <string>

#include "run/probes.hpp"
#include "run/progress.hpp"
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
  // The command that continues this run after a stop: the command line as given, --force dropped and --resume added
  // (with --tolerance, --seeds and every other option kept, so that the resume is accepted as printed). Empty:
  // "celldem run DECK --out DIR --resume".
  std::string continue_command;
};

}  // namespace celldem
