#include "measure/quasi_static.hpp"

#include <cmath>
#include <cstdio>
#include <limits>

#include "measure/micro.hpp"

namespace celldem {

std::string EquilibriumCheck::describe() const {
  char buf[160];
  std::snprintf(buf, sizeof buf, "p %.1f kPa  |dp| %.2g  max|ds| %.2g  unbalanced %.2g", p / 1e3, pressure_error,
                max_stress_error, unbalanced);
  return buf;
}

namespace {
// unbalanced_force: the unbalanced force ratio of the state's contacts (read only when something touches).
template <class UnbalancedForce>
EquilibriumCheck equilibrium(const State& state, UnbalancedForce unbalanced_force, const EquilibriumDef& criterion,
                             const Vec3& targets) {
  EquilibriumCheck c;
  // An isotropic target is used as given, not as a mean of three equal numbers (which may round).
  const double target = targets[0] == targets[1] && targets[1] == targets[2] ? targets[0] : targets.mean();
  c.p = state.mean_stress();
  c.pressure_error = std::abs(c.p - target) / target;
  for (int k = 0; k < 3; ++k)
    c.max_stress_error =
        std::max(c.max_stress_error, std::abs(state.stress[k] - targets[k]) / targets[k]);
  c.unbalanced = state.touching ? unbalanced_force() : 1.0;
  c.reached = state.touching > 0 && c.pressure_error <= criterion.pressure_tolerance &&
              c.max_stress_error <= criterion.stress_tolerance && c.unbalanced <= criterion.unbalanced_force_ratio;
  return c;
}
}  // namespace

EquilibriumCheck check_equilibrium(const Model& model, const State& state, const EquilibriumDef& criterion,
                                   const Vec3& targets) {
  return equilibrium(state, [&] { return measure_contacts(model, state).unbalanced_force; }, criterion, targets);
}

EquilibriumCheck check_equilibrium(const State& state, const ContactMeasures& contacts, const EquilibriumDef& criterion,
                                   const Vec3& targets) {
  return equilibrium(state, [&] { return contacts.unbalanced_force; }, criterion, targets);
}

double deviatoric_shear_rate(const Mat3& velocity_gradient) {
  const Mat3 d = 0.5 * (velocity_gradient + velocity_gradient.transpose());
  const Mat3 deviator = d - (d.trace() / 3.0) * Mat3::Identity();
  return std::sqrt(2.0 * deviator.squaredNorm());  // squaredNorm: D':D', the sum of the squared entries
}

double cell_inertial_number(const State& state, double density, double mean_stress) {
  if (state.control.stage_steps == 0) return 0.0;
  if (!(mean_stress > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return inertial_number(deviatoric_shear_rate(state.cell.velocity_gradient), mean_particle_diameter(state.particles),
                         density, mean_stress);
}

}  // namespace celldem
