// The energy budget (measure/energy.hpp) against analytic answers: a head-on collision of two spheres (the
// leapfrog's energy closes to round-off while they touch; a damped one loses what its restitution says), an
// overdamped pair returning from a pressed start (the dissipation in closed form), and a contact driven to
// slide (dissipation = mu fn x slip). Units: spheres of unit mass (testing::kUnitMassDensity), kn = 1e4.
#include <gtest/gtest.h>

#include <cmath>

#include "contact/contact_law.hpp"
#include "helpers.hpp"
#include "measure/energy.hpp"
#include "step.hpp"

namespace celldem {
namespace {

constexpr double kKn = 1.0e4;

struct Pair {
  Model model;
  State state;
};

// Two unit spheres (r = 0.5) on the x axis, `overlap` apart from touching, moving towards each other at
// v each, with body damping fraction a; the budget opened at the start (evaluate_forces).
Pair pressed_pair(double overlap, double v, double a, double dt) {
  Deck deck = testing::model_deck(kKn, kKn, dt, testing::kUnitMassDensity, a, 0.0);
  deck.energy_budget = true;
  State s = testing::make_state(Mat3::Identity() * 8.0, {0.5, 0.5},
                                {Vec3(2.0, 4.0, 4.0), Vec3(3.0 - overlap, 4.0, 4.0)}, 0.1);
  s.particles.velocity[0] = Vec3(v, 0.0, 0.0);
  s.particles.velocity[1] = Vec3(-v, 0.0, 0.0);
  Pair p{make_model(deck, s.particles.radius), std::move(s)};
  evaluate_forces(p.model, Friction{}, p.state);
  return p;
}

double total_energy(const Pair& p) { return energy_partition(p.model, p.state).total(); }

TEST(Energy, UndampedCollisionClosesToRoundOffWhileTouching) {
  const double dt = 2e-5;
  Pair p = pressed_pair(1e-6, 1.0, 0.0, dt);
  const double e0 = total_energy(p);
  ASSERT_NEAR(e0, 1.0, 1e-3);  // two unit masses at 1 m/s (and a tiny spring)
  const Loading fixed = testing::fixed_cell();
  int touching_steps = 0;
  double worst = 0.0;
  for (int k = 0; k < 5000 && (k == 0 || p.state.touching > 0); ++k) {
    testing::advance_one_step(p.model, fixed, p.state, k == 0);
    if (p.state.touching == 0) break;
    ++touching_steps;
    worst = std::max(worst, std::abs(energy_budget(p.model, p.state).closure));
  }
  EXPECT_GT(touching_steps, 1000);  // half a period, pi sqrt(m*/kn) / dt = 1111 steps
  // Round-off: positions near 3 m carry 4e-16 m, an overlap's step kn d 4e-16 = 6e-14 J at most: seen 1.2e-12 J
  // after 1111 steps.
  EXPECT_LT(worst, 1e-11 * e0) << "closure while touching";
  // Nothing was dissipated and the cell did no work.
  const EnergyBudget b = energy_budget(p.model, p.state);
  EXPECT_EQ(b.totals.boundary_work, 0.0);
  EXPECT_EQ(b.totals.dissipated(), 0.0);
}

TEST(Energy, SeparationLeavesOnlyTheLastStepsSpringEnergy) {
  // When the spheres part, the spring of the last touching step (overlap d < |v| dt) acts for a whole step: the
  // leapfrog's energy then changes by at most kn d |v| dt, the discrete error of the contact's end.
  const double dt = 2e-5, v = 1.0;
  Pair p = pressed_pair(1e-6, v, 0.0, dt);
  const Loading fixed = testing::fixed_cell();
  bool touched = false;
  for (int k = 0; k < 5000; ++k) {
    testing::advance_one_step(p.model, fixed, p.state, k == 0);
    touched = touched || p.state.touching > 0;
    if (touched && p.state.touching == 0) break;
  }
  const double bound = kKn * (2.0 * v * dt) * (2.0 * v * dt);
  EXPECT_LT(std::abs(energy_budget(p.model, p.state).closure), bound);
}

TEST(Energy, DampedCollisionLosesWhatItsRestitutionSays) {
  // Equal spheres with body damping a: the relative motion is a damped oscillator with zeta = a / sqrt(2), and
  // e = exp(-zeta pi / sqrt(1 - zeta^2)); the kinetic energy of the relative motion falls by 1 - e^2.
  const double dt = 2e-6, a = 0.2;
  Pair p = pressed_pair(0.0, 1.0, a, dt);
  const double e0 = total_energy(p);
  const Loading fixed = testing::fixed_cell();
  double worst = 0.0;
  for (int k = 0; k < 50000; ++k) {
    testing::advance_one_step(p.model, fixed, p.state, k == 0);
    if (k > 10 && p.state.touching == 0) break;
    worst = std::max(worst, std::abs(energy_budget(p.model, p.state).closure));
  }
  const EnergyBudget b = energy_budget(p.model, p.state);
  const double zeta = a / std::sqrt(2.0);
  const double e = std::exp(-zeta * M_PI / std::sqrt(1.0 - zeta * zeta));
  EXPECT_NEAR(b.partition.total() / e0, e * e, 2e-3 * e * e);
  EXPECT_NEAR(b.totals.damping_translation / e0, 1.0 - e * e, 2e-3);
  EXPECT_LT(worst, 1e-11 * e0) << "closure, damping included, while touching";
}

TEST(Energy, OverdampedPairDissipatesTheClosedForm) {
  // Pressed by d0 at rest, equal spheres with body damping a > sqrt(2) (zeta > 1) creep apart without
  // overshoot: u = -d0 (r2 e^(r1 t) - r1 e^(r2 t)) / (r2 - r1), r = w (-zeta -+ sqrt(zeta^2 - 1)), w = sqrt(2 kn / m);
  // the budget's damping must equal E(0) - E(t), E = kn u^2 / 2 + m u'^2 / 4.
  const double dt = 1e-6, a = 2.0, d0 = 1e-3, m = 1.0;
  Pair p = pressed_pair(d0, 0.0, a, dt);
  const double w = std::sqrt(2.0 * kKn / m), zeta = a / std::sqrt(2.0);
  const double r1 = w * (-zeta - std::sqrt(zeta * zeta - 1.0)), r2 = w * (-zeta + std::sqrt(zeta * zeta - 1.0));
  const auto energy = [&](double t) {
    const double u = -d0 * (r2 * std::exp(r1 * t) - r1 * std::exp(r2 * t)) / (r2 - r1);
    const double du = -d0 * r1 * r2 * (std::exp(r1 * t) - std::exp(r2 * t)) / (r2 - r1);
    return 0.5 * kKn * u * u + 0.25 * m * du * du;
  };
  const Loading fixed = testing::fixed_cell();
  const int steps = 20000;  // t = 0.02 s, about 0.8 of the slow time constant 1/|r2|
  for (int k = 0; k < steps; ++k) testing::advance_one_step(p.model, fixed, p.state, k == 0);
  const double dissipated = energy(0.0) - energy(steps * dt);
  const EnergyBudget b = energy_budget(p.model, p.state);
  EXPECT_NEAR(b.totals.damping_translation, dissipated, 2e-3 * dissipated);
  EXPECT_LT(std::abs(b.closure), 1e-10 * energy(0.0));
}

TEST(Energy, SlidingContactDissipatesFrictionTimesSlip) {
  // A contact at fixed overlap d driven tangentially at speed v for n steps: it sticks until the spring reaches
  // mu fn / kt, then slides; what the cap dissipates is mu fn times the slip, v n dt - mu fn / kt.
  ContactParams law;
  law.kn = kKn, law.kt = 0.5 * kKn, law.mu = 0.4;
  const double d = 1e-3, v = 0.05, dt = 1e-5;
  const int n = 2000;
  const Vec3 branch(1.0 - d, 0.0, 0.0);
  ContactHistory h;
  double dissipated = 0.0;
  for (int k = 0; k < n; ++k) {
    const ContactResult r =
        evaluate_contact<LinearLaw>(law, branch, 0.5, 0.5, Vec3(0.0, v, 0.0), Vec3::Zero(), Vec3::Zero(), h, dt);
    h.tangential = real3(r.tangential);
    dissipated += r.slip_work;
  }
  const double fn = law.kn * d;
  const double slip = v * n * dt - law.mu * fn / law.kt;
  EXPECT_NEAR(dissipated, law.mu * fn * slip, 1e-9 * law.mu * fn * slip);
  // The spring holds mu fn / kt: the rest of the work, v n dt mu fn less half the spring's, was dissipated.
  EXPECT_NEAR(vec3(h.tangential).norm(), law.mu * fn / law.kt, 1e-15);
}

}  // namespace
}  // namespace celldem
