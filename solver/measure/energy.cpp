#include "measure/energy.hpp"

#include <cmath>
#include <limits>

#include "contact/contact_law.hpp"
#include "measure/micro.hpp"

namespace celldem {

EnergyPartition energy_partition(const Model& model, const State& state) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const ContactDef& c = model.contact;
  const bool rotational = pl.rolling.size() == pl.size();
  EnergyPartition e;
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    const Vec3 branch = pair_branch(state, i, q);
    const Index j = pl.neighbor[q];
    const Vec3 n = branch.normalized();
    const double fn = pl.force[q].dot(n);
    const double ft2 = (pl.force[q] - fn * n).squaredNorm();
    const double ri = p.radius[i], rj = p.radius[j];
    const double overlap = ri + rj - branch.norm();
    const double a = std::sqrt(ri * rj / (ri + rj) * std::max(overlap, 0.0));
    const double kt = is_mindlin(c.tangential) ? tangential_stiffness_mindlin(c.effective_shear_modulus(), a) : c.kt;
    e.normal += c.normal == NormalModel::Hertz ? 0.4 * fn * overlap : 0.5 * fn * fn / c.kn;
    e.tangential += kt > 0.0 ? 0.5 * ft2 / kt : 0.0;
    if (rotational && c.rolling == RollingModel::Sds)
      e.rotational_springs += 0.5 * c.rolling_stiffness * pl.rolling[q].squaredNorm();
    if (rotational && c.twisting == TwistingModel::Marshall)
      e.rotational_springs += 0.25 * kt * a * a * pl.twist[q] * pl.twist[q];
  });
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = p.radius[i];
    const double m = model.mass_of(r), inertia = 0.4 * m * r * r;
    e.kinetic_translation += 0.5 * (m * p.velocity[i].squaredNorm() - model.dt * p.force[i].dot(p.velocity[i]));
    e.kinetic_rotation += 0.5 * (inertia * p.spin[i].squaredNorm() - model.dt * p.torque[i].dot(p.spin[i]));
  }
  return e;
}

void open_energy_budget(const Model& model, State& state) {
  const Mat3 moment = state.energy.last_moment;
  state.energy = EnergyLedger{};
  state.energy.open = true;
  state.energy.last_moment = moment;
  state.energy.start_energy = energy_partition(model, state).total();
}

EnergyBudget energy_budget(const Model& model, const State& state) {
  EnergyBudget b;
  b.partition = energy_partition(model, state);
  b.totals = state.energy;
  if (!state.energy.open) {
    constexpr double nan = std::numeric_limits<double>::quiet_NaN();
    b.totals.boundary_work = b.totals.friction = b.totals.rotational_friction = b.totals.contact_damping = nan;
    b.totals.damping_translation = b.totals.damping_rotation = nan;
    b.closure = b.closure_relative = nan;
    return b;
  }
  const EnergyLedger& t = state.energy;
  b.closure = t.boundary_work - (b.partition.total() - t.start_energy) - t.dissipated();
  b.closure_relative = t.boundary_work != 0.0 ? b.closure / t.boundary_work : std::numeric_limits<double>::quiet_NaN();
  return b;
}

}  // namespace celldem
