// Is the packing at rest, is the loading slow: the preparation's equilibrium criterion and the inertial
// number of a test.
#pragma once
#include <cmath>
#include <string>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "measure/micro.hpp"

namespace celldem {

// The preparation's end: |p - p_target|/p_target (p_target the mean of the targets), every
// |s_kk - target_k|/target_k and the unbalanced force ratio within the deck's tolerances (with at least
// one contact).
struct EquilibriumCheck {
  bool reached = false;
  double p = 0.0;                 // [Pa]
  double pressure_error = 0.0;    // |p - target| / target
  double max_stress_error = 0.0;  // max_k |s_kk - target| / target
  double unbalanced = 0.0;        // unbalanced force ratio (1 when nothing touches)
  std::string describe() const;   // "p 100.0 kPa  |dp| 0.001  max|ds| 0.002  unbalanced 0.009"
};
EquilibriumCheck check_equilibrium(const Model& model, const State& state, const EquilibriumDef& criterion,
                                   const Vec3& targets);
// The same from the state's contacts as measure_contacts measured them (a step that also writes a row measures
// them once for both).
EquilibriumCheck check_equilibrium(const State& state, const ContactMeasures& contacts, const EquilibriumDef& criterion,
                                   const Vec3& targets);

// Inertial number I = rate d sqrt(rho / p): the time a grain needs to rearrange under p over the loading
// time (quasi-static below about 1e-3). Infinite when p <= 0.
inline double inertial_number(double strain_rate, double diameter, double density, double mean_stress) {
  return mean_stress > 0.0 ? strain_rate * diameter * std::sqrt(density / mean_stress) : INFINITY;
}
inline constexpr double kQuasiStaticInertia = 1e-3;
// [1/s] the deviatoric shear rate of a velocity gradient L, the mu(I) rheology's gamma_dot in three dimensions
// (Jop, Forterre & Pouliquen 2006): gamma_dot = sqrt(2 D':D'), D = (L + L^T)/2 the strain rate, D' = D - tr(D)/3 I
// its deviator. A simple shear L = gamma e1 e2^T gives |gamma| (GDR MiDi 2004, da Cruz et al. 2005), an axial
// rate e1 with the two other axes at -e1/2 (isochoric) gives sqrt(3) |e1|, an isotropic L gives 0; the spin
// (the antisymmetric part of L) does not count (docs/physics.md).
double deviatoric_shear_rate(const Mat3& velocity_gradient);
// The inertial number of the cell's own deformation in its last step: I = gamma_dot d sqrt(rho / p) with
// gamma_dot = deviatoric_shear_rate(state.cell.velocity_gradient) (every component the cell moved, driven or
// servo-held), d the particles' mean diameter and p `mean_stress` (series `inertial_number`). 0 before the
// stage's first step (the cell's L is then the previous stage's), NaN when p <= 0.
double cell_inertial_number(const State& state, double density, double mean_stress);
// [m] the particles' mean diameter, the d of a running stage's inertial number (series `inertial_number`, the
// adaptive rate's ceiling); 0 without particles.
inline double mean_particle_diameter(const Particles& p) {
  double sum = 0.0;
  for (const double r : p.radius) sum += 2.0 * r;
  return p.size() ? sum / static_cast<double>(p.size()) : 0.0;
}

}  // namespace celldem
