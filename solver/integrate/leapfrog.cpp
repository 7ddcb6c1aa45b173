#include "integrate/leapfrog.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/check.hpp"
#include "core/isa_clones.hpp"
#include "core/parallel.hpp"

namespace celldem {

namespace {
// Particle i's net force and moment, summed from its pairs in a fixed order (PairList::incoming_pair): the
// pairs coming into it from its force block, its own pairs, then the pairs crossing into it from earlier
// blocks, each in pair order (j gets +F, i gets -F). Pairs apart hold zero force and moment, so adding them
// changes nothing (and needs no branch).
inline void gather(const PairList& pl, Particles& p, std::size_t i) {
  Vec3 f = Vec3::Zero(), t = Vec3::Zero();
  const Index crossing = pl.incoming_crossing[i];
  for (Index k = pl.incoming_first[i]; k < crossing; ++k) {
    const Index q = pl.incoming_pair[k];
    f += pl.force[q];
    t += pl.torque_j[q];
  }
  for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q) {
    f -= pl.force[q];
    t += pl.torque_i[q];
  }
  for (Index k = crossing; k < pl.incoming_first[i + 1]; ++k) {
    const Index q = pl.incoming_pair[k];
    f += pl.force[q];
    t += pl.torque_j[q];
  }
  p.force[i] = f;
  p.torque[i] = t;
}

// The calling thread's share of the particles: a contiguous range with about equal work (its pairs, both
// ways, plus the particle itself).
std::pair<std::size_t, std::size_t> gather_share(const PairList& pl, std::size_t n) {
  return thread_share(n, [&](std::size_t k) {
    return static_cast<std::size_t>(pl.incoming_first[k]) + static_cast<std::size_t>(pl.first[k]) + k;
  });
}
}  // namespace

void gather_forces(State& state) {
#pragma omp parallel
  {
    const auto [begin, end] = gather_share(state.pairs, state.particles.size());
    for (std::size_t i = begin; i < end; ++i) gather(state.pairs, state.particles, i);
  }
}

// The kick and the drift as AVX-512/AVX2 clones, as the pair law: 1.6 % of a one-thread step, the same bits.
CELLDEM_ISA_CLONES
void gather_and_kick_range(const Model& model, State& state, std::size_t begin, std::size_t end) {
  Particles& p = state.particles;
  for (std::size_t i = begin; i < end; ++i) {
    gather(state.pairs, p, i);
    p.velocity[i] = model.velocity_keep[i] * p.velocity[i] + model.velocity_gain[i] * p.force[i];
    p.spin[i] = model.spin_keep[i] * p.spin[i] + model.spin_gain[i] * p.torque[i];
  }
}

void gather_and_kick_share(const Model& model, State& state, const std::vector<std::size_t>& blocks) {
  const std::size_t n = state.particles.size();
  for (const std::size_t b : blocks)
    gather_and_kick_range(model, state, b * kForceBlock, std::min(n, (b + 1) * kForceBlock));
}

CELLDEM_ISA_CLONES
double drift_share(const Model& model, const Mat3& h_before, State& state, const std::vector<std::size_t>& blocks) {
  Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const Mat3 step_map = model.dt * (0.5 * (h_before + state.cell.h)).inverse();
  const Mat3& h = state.cell.h;
  const std::size_t n = p.size();
  const bool built = pl.first.size() == n + 1 && pl.scaled_at_build.size() == n;
  double max_disp2 = 0.0;
  for (const std::size_t b : blocks)
    for (std::size_t i = b * kForceBlock; i < std::min(n, (b + 1) * kForceBlock); ++i) {
      p.scaled[i] += step_map * p.velocity[i];
      if (built) max_disp2 = std::max(max_disp2, (h * (p.scaled[i] - pl.scaled_at_build[i].cast<double>())).squaredNorm());
    }
  return built ? std::sqrt(max_disp2) : std::numeric_limits<double>::infinity();
}

}  // namespace celldem
