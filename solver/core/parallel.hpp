// Work sharing for the OpenMP loops. Each thread takes one contiguous range of items, with the ranges
// balanced by cost: contiguous so that a thread mostly reads what it wrote itself in the previous phase
// (particles are spatially ordered, so neighbours have nearby ids and cross-core traffic stays at the
// range boundaries), balanced because the particles at the ends of the order own fewer pairs.
#pragma once
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace celldem {

// The calling thread's share [begin, end) of items 0 .. count-1, where cost_before(k) is the total cost of
// items 0 .. k-1 (non-decreasing, as CSR offsets are). Call inside a parallel region.
template <class CostBefore>
std::pair<std::size_t, std::size_t> thread_share(std::size_t count, CostBefore cost_before) {
  const auto t = static_cast<std::size_t>(omp_get_thread_num()), threads = static_cast<std::size_t>(omp_get_num_threads());
  const double total = static_cast<double>(cost_before(count));
  auto boundary = [&](std::size_t s) {  // first item at which the cumulative cost reaches s/threads of the total
    if (s == 0) return std::size_t{0};
    if (s == threads) return count;
    const double target = total * static_cast<double>(s) / static_cast<double>(threads);
    std::size_t lo = 0, hi = count;
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      if (static_cast<double>(cost_before(mid)) < target) lo = mid + 1;
      else hi = mid;
    }
    return lo;
  };
  return {boundary(t), boundary(t + 1)};
}

// The calling thread's share of `count` blocks of work, in ascending order, with cost_before as for
// thread_share. Many blocks per thread: the contiguous run thread_share gives. Few: whole blocks are too
// coarse for contiguous runs to balance (four blocks of unequal cost on two threads), so they are dealt out,
// the costliest first, each to the least loaded thread. Every thread computes the same deal.
template <class CostBefore>
std::vector<std::size_t> thread_blocks(std::size_t count, CostBefore cost_before) {
  const auto t = static_cast<std::size_t>(omp_get_thread_num()), threads = static_cast<std::size_t>(omp_get_num_threads());
  std::vector<std::size_t> mine;
  if (threads == 1 || count >= 8 * threads) {
    const auto [begin, end] = thread_share(count, cost_before);
    for (std::size_t b = begin; b < end; ++b) mine.push_back(b);
    return mine;
  }
  const auto cost = [&](std::size_t b) { return static_cast<double>(cost_before(b + 1) - cost_before(b)); };
  std::vector<std::size_t> order(count);
  for (std::size_t b = 0; b < count; ++b) order[b] = b;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cost(a) > cost(b); });
  std::vector<double> load(threads, 0.0);
  for (const std::size_t b : order) {
    const auto least = static_cast<std::size_t>(std::min_element(load.begin(), load.end()) - load.begin());
    load[least] += cost(b);
    if (least == t) mine.push_back(b);
  }
  std::sort(mine.begin(), mine.end());
  return mine;
}

// A barrier for the threads of one parallel region that waits by spinning first, whatever OMP_WAIT_POLICY
// says: inside a time step the threads meet within microseconds, far less than it takes the kernel to wake a
// sleeping thread (with OMP_WAIT_POLICY=PASSIVE, OpenMP's own barriers made two threads slower than one).
// A thread still waiting after the spin (its partner descheduled, or more threads than cores) sleeps on the
// generation counter instead of burning the core its partner may need.
class SpinBarrier {
 public:
  explicit SpinBarrier(int threads) : threads_(threads) {}
  void wait() {
    if (threads_ == 1) return;
    const unsigned generation = generation_.load(std::memory_order_acquire);
    // The last to arrive opens the barrier; its acq_rel increment has seen every earlier arrival's writes.
    if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == threads_) {
      arrived_.store(0, std::memory_order_relaxed);
      generation_.store(generation + 1, std::memory_order_release);
      generation_.notify_all();  // a system call only if someone sleeps
      return;
    }
    for (int spins = 0; spins < kSpins; ++spins) {
      if (generation_.load(std::memory_order_acquire) != generation) return;
#if defined(__x86_64__) || defined(__i386__)
      __builtin_ia32_pause();
#endif
    }
    while (generation_.load(std::memory_order_acquire) == generation)
      generation_.wait(generation, std::memory_order_acquire);
  }

 private:
  static constexpr int kSpins = 4000;  // some 0.1 ms of pauses
  const int threads_;
  alignas(64) std::atomic<int> arrived_{0};
  alignas(64) std::atomic<unsigned> generation_{0};
};

// The threads of one parallel region that work through many phases in lockstep (the time step's:
// advance_steps): they meet at a SpinBarrier, run serial sections on one thread while the others wait, and
// leave the region together when a serial section throws. Made before the region; every thread calls
// join() first and works through its Member; after the region the caller calls rethrow().
class Team {
 public:
  class Member;
  Member join();                // every thread, at the start of the region
  void rethrow() const {        // after the region: the exception that ended it, if any
    if (failure_) std::rethrow_exception(failure_);
  }

 private:
  std::optional<SpinBarrier> barrier_;
  std::exception_ptr failure_;  // written by thread 0 only, read after the region
  // The serial section that threw (counted alike on every thread), none yet: the largest count. A count,
  // not a flag, so that a thread still reading the outcome of section k while thread 0 has already failed
  // in section k + 1 goes on to section k + 1 and meets thread 0 there, instead of leaving one section early.
  std::atomic<std::int64_t> failed_section_{std::numeric_limits<std::int64_t>::max()};
};

// One thread's handle on its team.
class Team::Member {
 public:
  int thread() const { return thread_; }
  int size() const { return size_; }
  void wait() { team_.barrier_->wait(); }  // every thread of the team
  // Runs f on thread 0 while the others wait, then all meet. Returns false, on every thread alike, if f
  // threw: then every thread leaves the region (the exception is kept for Team::rethrow()).
  template <class F>
  bool serial(F&& f) {
    ++section_;
    if (thread_ == 0) {
      try {
        f();
      } catch (...) {
        team_.failure_ = std::current_exception();
        team_.failed_section_.store(section_, std::memory_order_release);
      }
    }
    wait();
    return team_.failed_section_.load(std::memory_order_acquire) > section_;
  }

 private:
  friend class Team;
  Member(Team& team, int thread, int size) : team_(team), thread_(thread), size_(size) {}
  Team& team_;
  const int thread_, size_;
  std::int64_t section_ = 0;  // serial sections entered
};

inline Team::Member Team::join() {
#pragma omp single
  barrier_.emplace(omp_get_num_threads());  // (the end of single is a barrier: all see it built)
  return Member(*this, omp_get_thread_num(), omp_get_num_threads());
}

}  // namespace celldem
