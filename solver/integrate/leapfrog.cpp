#include "integrate/leapfrog.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/check.hpp"
#include "core/isa_clones.hpp"
#include "core/parallel.hpp"
#include "neighbor/neighbor_list.hpp"

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

namespace {
// The kick of particles [begin, end) once their net forces and moments are summed: v' = keep v' + gain F and
// the same for the spin, per component as Eigen's `keep * v + gain * f`, on plain arrays in SIMD lanes.
CELLDEM_ISA_CLONES
void kick_range(const double* __restrict keep, const double* __restrict gain, const double* __restrict force,
                double* __restrict velocity, std::size_t n) {
  CELLDEM_SIMD()
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) velocity[3 * i + c] = keep[i] * velocity[3 * i + c] + gain[i] * force[3 * i + c];
}
// The same kick, one particle after the other, returning what the body damping dissipated (the energy budget):
// with a = c dt / 2m, keep = (1 - a)/(1 + a) and gain = dt/(m (1 + a)), the update is m (v+ - v-) = dt F - c dt v̄,
// v̄ = (v- + v+)/2, so the kinetic energy changes by dt F.v̄ - c dt |v̄|^2: the damping took c dt |v̄|^2, and
// c dt = dt (1 - keep) / gain. The velocities are those of kick_range to the bit (the same products and sum).
double kick_range_measured(const double* keep, const double* gain, const double* force, double* velocity, std::size_t n,
                           double dt) {
  double work = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    double mean2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double before = velocity[3 * i + c];
      const double after = keep[i] * before + gain[i] * force[3 * i + c];
      velocity[3 * i + c] = after;
      const double mean = 0.5 * (before + after);
      mean2 += mean * mean;
    }
    work += dt * (1.0 - keep[i]) / gain[i] * mean2;
  }
  return work;
}
}  // namespace

// The net forces (scalar sums of varying length), then the kick on the block in SIMD lanes.
CELLDEM_ISA_CLONES
void gather_and_kick_range(const Model& model, State& state, std::size_t begin, std::size_t end, KickDamping* damping) {
  Particles& p = state.particles;
  if (begin >= end) return;
  for (std::size_t i = begin; i < end; ++i) gather(state.pairs, p, i);
  const std::size_t n = end - begin;
  if (damping) {
    damping->translation = kick_range_measured(&model.velocity_keep[begin], &model.velocity_gain[begin],
                                               p.force[begin].data(), p.velocity[begin].data(), n, model.dt);
    damping->rotation = kick_range_measured(&model.spin_keep[begin], &model.spin_gain[begin], p.torque[begin].data(),
                                            p.spin[begin].data(), n, model.dt);
    return;
  }
  kick_range(&model.velocity_keep[begin], &model.velocity_gain[begin], p.force[begin].data(), p.velocity[begin].data(), n);
  kick_range(&model.spin_keep[begin], &model.spin_gain[begin], p.torque[begin].data(), p.spin[begin].data(), n);
}

void gather_and_kick_share(const Model& model, State& state, const std::vector<std::size_t>& blocks,
                           std::vector<KickDamping>* damping) {
  const std::size_t n = state.particles.size();
  for (const std::size_t b : blocks)
    gather_and_kick_range(model, state, b * kForceBlock, std::min(n, (b + 1) * kForceBlock),
                          damping ? &(*damping)[b] : nullptr);
}

namespace {
// The drift of n particles, s += M v' with M = dt h_mid^-1, on plain arrays so that it runs in SIMD lanes
// (Vec3's scalar code took most of the drift's time). M v' is summed as Eigen's 3x3 product sums it, so that
// the positions are those of `scaled += M * velocity` to the bit: rows 1 and 2 left to right, row 3 as
// a + (b + c) (Eigen's reduction of a strided row). Eigen fuses its products' multiply-adds where the build
// targets FMA (CELLDEM_NATIVE on such a CPU), and this code does not, so there the bits differ from Eigen's;
// the default build's clones are compiled with Eigen's SSE2 code, unfused. (Test: tests/integrate/test_leapfrog.cpp,
// Leapfrog.DriftIsEigensProductToTheBitAndMeasuresTheLargestMove.)
CELLDEM_ISA_CLONES
void drift_range(const Mat3& step_map, double* __restrict scaled, const double* __restrict velocity, std::size_t n) {
  const double m00 = step_map(0, 0), m01 = step_map(0, 1), m02 = step_map(0, 2), m10 = step_map(1, 0),
               m11 = step_map(1, 1), m12 = step_map(1, 2), m20 = step_map(2, 0), m21 = step_map(2, 1),
               m22 = step_map(2, 2);
  CELLDEM_SIMD()
  for (std::size_t i = 0; i < n; ++i) {
    const double vx = velocity[3 * i], vy = velocity[3 * i + 1], vz = velocity[3 * i + 2];
    scaled[3 * i] += (m00 * vx + m01 * vy) + m02 * vz;
    scaled[3 * i + 1] += (m10 * vx + m11 * vy) + m12 * vz;
    scaled[3 * i + 2] += m20 * vx + (m21 * vy + m22 * vz);
  }
}
}  // namespace

double drift_share(const Model& model, const Mat3& h_before, State& state, const std::vector<std::size_t>& blocks) {
  Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const Mat3 step_map = model.dt * (0.5 * (h_before + state.cell.h)).inverse();
  const std::size_t n = p.size();
  const bool built = pl.first.size() == n + 1 && pl.scaled_at_build.size() == n;
  double max_disp2 = 0.0;
  for (const std::size_t b : blocks) {
    const std::size_t begin = b * kForceBlock, end = std::min(n, (b + 1) * kForceBlock);
    if (begin >= end) continue;
    drift_range(step_map, p.scaled[begin].data(), p.velocity[begin].data(), end - begin);
    if (built) max_disp2 = std::max(max_disp2, largest_move2(state.cell.h, p, pl, begin, end));  // (the block in cache)
  }
  return built ? std::sqrt(max_disp2) : std::numeric_limits<double>::infinity();
}

}  // namespace celldem
