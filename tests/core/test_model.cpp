// The immutable model (solver/core/model.hpp): masses, inertias and the damped leapfrog coefficients,
// against their formulas written out by hand.
#include <gtest/gtest.h>

#include <cmath>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/plan.hpp"
#include "helpers.hpp"
#include "io/deck_reader.hpp"

namespace celldem {
namespace {

TEST(Model, MassesAndUndampedCoefficients) {
  const double dt = 1e-4, density = 2500.0;
  const std::vector<double> radius = {0.5, 0.25, 1.0};
  const Model m = make_model(testing::model_deck(1e4, 5e3, dt, density), radius);
  ASSERT_EQ(m.velocity_gain.size(), 3u);
  double volume = 0.0;
  for (std::size_t i = 0; i < radius.size(); ++i) {
    const double r = radius[i], v = 4.0 / 3.0 * M_PI * r * r * r, mass = density * v;
    volume += v;
    EXPECT_NEAR(m.mass_of(r), mass, 1e-12 * mass);
    EXPECT_EQ(m.velocity_keep[i], 1.0);
    EXPECT_EQ(m.spin_keep[i], 1.0);
    EXPECT_NEAR(m.velocity_gain[i], dt / mass, 1e-15 * dt / mass);
    EXPECT_NEAR(m.spin_gain[i], dt / (0.4 * mass * r * r), 1e-12 * dt / (0.4 * mass * r * r));
  }
  EXPECT_NEAR(m.solid_volume, volume, 1e-12 * volume);
  EXPECT_EQ(m.max_radius, 1.0);
  EXPECT_EQ(m.dt, dt);
}

// Body damping, a fraction of critical: c = a 2 sqrt(m kn) on translation, c_r = a_r 2 r sqrt(I kt) on
// rotation, integrated implicitly (trapezoidal): keep = (1 - c dt/2m)/(1 + c dt/2m), gain = dt/(m (1 + c dt/2m)).
TEST(Model, DampedCoefficients) {
  const double dt = 2e-4, kn = 1e4, kt = 4e3, at = 0.3, ar = 0.2;
  const Model m = make_model(testing::model_deck(kn, kt, dt, testing::kUnitMassDensity, at, ar), {0.5});
  const double mass = 1.0, inertia = 0.4 * 0.25;
  const double c = at * 2.0 * std::sqrt(mass * kn), cr = ar * 2.0 * 0.5 * std::sqrt(inertia * kt);
  const double x = c * dt / (2 * mass), xr = cr * dt / (2 * inertia);
  EXPECT_NEAR(m.velocity_keep[0], (1 - x) / (1 + x), 1e-15);
  EXPECT_NEAR(m.velocity_gain[0], dt / (mass * (1 + x)), 1e-18);
  EXPECT_NEAR(m.spin_keep[0], (1 - xr) / (1 + xr), 1e-15);
  EXPECT_NEAR(m.spin_gain[0], dt / (inertia * (1 + xr)), 1e-15);
  EXPECT_LT(m.velocity_keep[0], 1.0);
  EXPECT_GT(m.velocity_keep[0], 0.0);
}

// The run's estimate: the preparation's fast compression takes as many steps as the cell control
// (advance_cell) takes to bring the grid sample's cell to the solid fraction (counted here step by step), its
// servo leg between the equilibrium's min and max steps; the tests their planned steps; memory per sphere as
// measured.
TEST(Plan, RunEstimateCountsThePreparationsCompressionStepByStep) {
  const Deck deck = parse_deck(testing::small_deck_json(1000, R"([{"name": "t", "friction": 0.5,
      "axes": {"x1": {"strain_increment": 1e-5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
      "end": {"axis": "x1", "strain": 0.01}}])"));
  double solid = 0.0;
  for (double d : deck.sample.diameters) solid += M_PI / 6.0 * d * d * d / 4.0;
  State cell = testing::make_state(Mat3::Identity() * (10 * 5e-3), {}, {}, 0.0);  // 10^3 grid sites 5 mm apart
  begin_stage(cell);
  const Model model = make_model(deck, {});
  Loading fast_leg;
  std::fill_n(fast_leg.axes.begin(), 3, AxisControl{AxisMode::StrainIncrement, 1e-4});
  std::int64_t fast = 0;
  for (; 1000 * solid / cell.cell.volume() < 0.55; ++fast) advance_cell(model, fast_leg, cell);
  const RunEstimate e = estimate_run(deck);
  EXPECT_EQ(e.preparation.low, fast + 1000);  // the servo leg's min_steps
  EXPECT_EQ(e.preparation.high, fast + 200000);
  EXPECT_EQ(e.tests.low, 1000);
  EXPECT_EQ(e.tests.high, 1000);
  EXPECT_DOUBLE_EQ(e.particle_steps_low, 1000.0 * (fast + 2000));
  EXPECT_DOUBLE_EQ(e.bytes, 1000 * kBytesPerParticle);
}

}  // namespace
}  // namespace celldem
