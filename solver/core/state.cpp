#include "core/state.hpp"

#include "core/check.hpp"
#include "core/parallel.hpp"

namespace celldem {

void Particles::resize(std::size_t n) {
  radius.resize(n);
  scaled.resize(n, Vec3::Zero());
  velocity.resize(n, Vec3::Zero());
  spin.resize(n, Vec3::Zero());
  force.resize(n, Vec3::Zero());
  torque.resize(n, Vec3::Zero());
}

std::vector<std::size_t> thread_force_blocks(const PairList& pl, std::size_t n) {
  const bool built = pl.first.size() == n + 1;
  return thread_blocks((n + kForceBlock - 1) / kForceBlock, [&](std::size_t b) {
    const std::size_t first = std::min(n, b * kForceBlock);
    return built ? static_cast<std::size_t>(pl.first[first]) : first;
  });
}

void check_force_block_partition(const std::vector<std::vector<std::size_t>>& dealt, std::size_t n) {
  const auto require = [](bool ok, const char* what) {
    if (!ok) detail::invariant_failed("check_force_block_partition", what, __FILE__, __LINE__);
  };
  std::vector<int> takers((n + kForceBlock - 1) / kForceBlock, 0);
  for (const std::vector<std::size_t>& mine : dealt)
    for (std::size_t k = 0; k < mine.size(); ++k) {
      require(mine[k] < takers.size(), "a dealt force block exists");
      require(k == 0 || mine[k - 1] < mine[k], "a thread's force blocks ascend");
      ++takers[mine[k]];
    }
  for (const int t : takers) require(t == 1, "every force block is dealt to exactly one thread");
}

}  // namespace celldem
