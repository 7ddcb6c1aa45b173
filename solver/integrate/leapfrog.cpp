#include "integrate/leapfrog.hpp"

namespace celldem {

void gather_and_kick(const Model& model, State& state) {
  Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const std::size_t n = p.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 f = Vec3::Zero(), t = Vec3::Zero();
    // Per-pair results are only valid where the pair touches (the pair loop skips the others).
    for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q) {
      if (!(pl.flags[q] & kTouching)) continue;
      f -= pl.force[q];
      t += pl.torque_i[q];
    }
    for (Index k = pl.incoming_first[i]; k < pl.incoming_first[i + 1]; ++k) {
      const Index q = pl.incoming[k];
      if (!(pl.flags[q] & kTouching)) continue;
      f += pl.force[q];
      t += pl.torque_j[q];
    }
    p.force[i] = f;
    p.torque[i] = t;
    p.velocity[i] = model.velocity_keep[i] * p.velocity[i] + model.velocity_gain[i] * f;
    p.spin[i] = model.spin_keep[i] * p.spin[i] + model.spin_gain[i] * t;
  }
}

void drift(const Model& model, const Mat3& h_before, State& state) {
  Particles& p = state.particles;
  const Mat3 step_map = model.dt * (0.5 * (h_before + state.cell.h)).inverse();
  const std::size_t n = p.size();
#pragma omp parallel for schedule(static)
  for (std::size_t i = 0; i < n; ++i) p.scaled[i] += step_map * p.velocity[i];
}

}  // namespace celldem
