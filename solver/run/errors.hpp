// The run layer's floor: its three kinds of failure and the stop request that every part of a run (stages, probes,
// rate checks, merges) shares, with no other run/ header below it, so that no file of run/ needs the runner's.
#pragma once
#include <stdexcept>

namespace celldem {

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

// Installs SIGINT/SIGTERM handlers that ask the running stage to checkpoint and stop.
void install_stop_handlers();
bool stop_requested();

}  // namespace celldem
