// Keeps a stage on the faster of its thread count and one thread while it runs. Results are the same bits
// on any thread count, so switching costs nothing but the trial. Under contention (another busy process
// on one of the cores) the threads of a parallel loop wait for the slowest at every barrier and two
// threads run slower than one; the governor finds that within one period and finds its way back when the
// other process is gone.
#pragma once
#include <chrono>
#include <cstdint>

namespace celldem {

class ThreadGovernor {
 public:
  // threads: the stage's thread count (1: the governor does nothing). Every `period` steps it times
  // `window` steps on each count and keeps the faster until the next trial.
  explicit ThreadGovernor(int threads, std::int64_t period = 10000, std::int64_t window = 100);

  // After each step: counts it and times trials. Returns true when the thread count for the next steps,
  // current(), has changed (the caller's parallel region must end for it to take effect).
  bool step_done();
  int current() const { return current_; }
  int switches() const { return switches_; }  // trials that changed the count
  int trials() const { return trials_; }

 private:
  enum class Phase { Running, TryingMany, TryingOne };
  bool use(int threads);

  using Clock = std::chrono::steady_clock;
  int threads_;
  std::int64_t period_, window_;
  int current_;  // the thread count for the steps now
  int chosen_;   // the count the last trial chose
  int switches_ = 0, trials_ = 0;
  Phase phase_ = Phase::Running;
  std::int64_t steps_ = 0;  // in the current phase
  Clock::time_point start_;
  double many_seconds_ = 0.0;
};

}  // namespace celldem
