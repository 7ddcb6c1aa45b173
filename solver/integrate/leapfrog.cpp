#include "integrate/leapfrog.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/check.hpp"
#include "core/isa_clones.hpp"
#include "core/parallel.hpp"

namespace celldem {

namespace {
// Completes particle i's net force and moment: the pair loop summed the pairs of i's force block (kForceBlock)
// where i is either end; the pairs that cross into it from other blocks come here, in ascending pair order.
// Pairs apart hold zero force and moment, so adding them changes nothing (and needs no branch). (Nor does
// the sign of a zero: a net force starts from +0 and sums reach -0 only from two -0 terms, so f is never
// -0, and f + (-0) = f + (+0) = f.)
inline void gather(const PairList& pl, Particles& p, std::size_t i) {
  Vec3 f = p.force[i], t = p.torque[i];
  for (Index k = pl.crossing_first[i]; k < pl.crossing_first[i + 1]; ++k) {
    CELLDEM_ASSERT(pl.crossing_rank[k] >= 0 && static_cast<std::size_t>(pl.crossing_rank[k]) < pl.crossing_torque.size(),
                   "a crossing pair's rank lies within crossing_torque");
    CELLDEM_ASSERT(k == pl.crossing_first[i] || pl.crossing_rank[k - 1] < pl.crossing_rank[k],
                   "the pairs crossing into a particle are summed in pair order (their ranks ascend)");
    CELLDEM_ASSERT(pl.crossing_pair[k] >= 0 && static_cast<std::size_t>(pl.crossing_pair[k]) < pl.force.size(),
                   "a crossing pair is a listed pair");
    f += pl.force[pl.crossing_pair[k]];  // the force on j: the pair's own
    t += pl.crossing_torque[pl.crossing_rank[k]];
  }
  p.force[i] = f;
  p.torque[i] = t;
}

// The calling thread's share of the particles: a contiguous range with about equal work (crossing pairs
// plus the particle itself).
std::pair<std::size_t, std::size_t> gather_share(const PairList& pl, std::size_t n) {
  return thread_share(n, [&](std::size_t k) { return static_cast<std::size_t>(pl.crossing_first[k]) + k; });
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
