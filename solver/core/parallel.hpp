// Work sharing for the OpenMP loops. Each thread takes one contiguous range of items, with the ranges
// balanced by cost: contiguous so that a thread mostly reads what it wrote itself in the previous phase
// (particles are spatially ordered, so neighbours have nearby ids and cross-core traffic stays at the
// range boundaries), balanced because the particles at the ends of the order own fewer pairs.
#pragma once
#include <omp.h>

#include <algorithm>
#include <cstddef>
#include <utility>

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

}  // namespace celldem
