#include "core/state.hpp"

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

}  // namespace celldem
