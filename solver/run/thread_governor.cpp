#include "run/thread_governor.hpp"

namespace celldem {

ThreadGovernor::ThreadGovernor(int threads, std::int64_t period, std::int64_t window)
    : threads_(threads), period_(period), window_(window), current_(threads), chosen_(threads) {}

bool ThreadGovernor::use(int threads) {
  const bool changed = threads != current_;
  current_ = threads;
  return changed;
}

bool ThreadGovernor::step_done() {
  if (threads_ <= 1) return false;
  ++steps_;
  switch (phase_) {
    case Phase::Running:
      // The first trial comes soon (two windows in: under contention two threads can be ten times slower
      // than one), the others every period.
      if (steps_ >= (trials_ == 0 ? 2 * window_ : period_)) {
        phase_ = Phase::TryingMany, steps_ = 0;
        start_ = Clock::now();
        return use(threads_);
      }
      break;
    case Phase::TryingMany:
      if (steps_ >= window_) {
        many_seconds_ = std::chrono::duration<double>(Clock::now() - start_).count();
        phase_ = Phase::TryingOne, steps_ = 0;
        start_ = Clock::now();
        return use(1);
      }
      break;
    case Phase::TryingOne:
      if (steps_ >= window_) {
        const double one_seconds = std::chrono::duration<double>(Clock::now() - start_).count();
        const int faster = one_seconds < many_seconds_ ? 1 : threads_;
        switches_ += faster != chosen_;
        chosen_ = faster;
        ++trials_;
        phase_ = Phase::Running, steps_ = 0;
        return use(faster);
      }
      break;
  }
  return false;
}

}  // namespace celldem
