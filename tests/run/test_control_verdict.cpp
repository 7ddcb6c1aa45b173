// The one verdict on a leg's controls (solver/run/control_verdict.hpp), on states set by hand: every controlled
// component of the six is measured against the servo's own targets, averaged over its span and judged once; a
// slip's spike passes, a lag that stays or an error that swings about the target fails, a leg shorter than its
// span is judged at its end; the record keeps its units, names its component and round-trips through JSON.
#include <gtest/gtest.h>

#include <cmath>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "run/control_verdict.hpp"
#include "run/health.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

constexpr double kP = 1.0e5;

Leg stress_leg() {  // x1 driven at 1e-6 per step, x2 and x3 at kP, x12 at a shear stress of 2e4
  Leg leg;
  leg.axes[0] = {AxisMode::StrainIncrement, 1e-6};
  leg.axes[1] = {AxisMode::Stress, kP};
  leg.axes[2] = {AxisMode::Stress, kP};
  leg.axes[3] = {AxisMode::Stress, 2.0e4};
  leg.end = {.kind = LegEndKind::Strain, .axis = 0, .value = 0.05};
  return leg;
}

State state_at(const Vec6& stress, std::int64_t steps) {
  State s;
  s.cell.h = Mat3::Identity();
  s.stress = stress;
  s.control.leg_steps = steps;
  s.control.leg_progress = static_cast<double>(steps);
  return s;
}

Vec6 held_stresses(double x2_error) {  // x2 off by x2_error (relative), the rest on target
  return (Vec6() << 2.0 * kP, kP * (1.0 + x2_error), kP, 2.0e4, 0.0, 0.0).finished();
}

Model unit_model() { return make_model(testing::model_deck(1e4, 1e4, 1e-6), {}); }

TEST(ControlVerdict, ChecksStartAfterTheSettleWindowAndSpanTheirStrain) {
  const Model model = unit_model();
  const LegChecks c(stress_leg(), model);
  EXPECT_TRUE(c.checked);
  EXPECT_EQ(c.settle, 2000);  // 0.2 % at 1e-6 per step
  EXPECT_EQ(c.span, 1000);    // 0.1 %
  Leg hold = stress_leg();    // nothing drives it: steps, not strain
  hold.axes[0] = {AxisMode::Stress, 2.0 * kP};
  hold.end = {.kind = LegEndKind::Steps, .steps = 5000};
  const LegChecks h(hold, model);
  EXPECT_TRUE(h.checked);
  EXPECT_EQ(h.settle, kRampSettleSteps);
  EXPECT_EQ(h.span, kMinPersistSteps);
  Leg equilibrium = hold;  // its criterion is its verdict
  equilibrium.end = {.kind = LegEndKind::Equilibrium};
  EXPECT_FALSE(LegChecks(equilibrium, model).checked);
}

TEST(ControlVerdict, EveryControlledComponentIsMeasuredTheShearStressIncluded) {
  const Model model = unit_model();
  const Leg leg = stress_leg();
  const LegChecks c(leg, model);
  ControlErrors e;
  for (std::int64_t n = c.settle; n < c.settle + 3 * c.span; ++n) {
    Vec6 s = held_stresses(0.001);
    s[3] = 2.0e4 + 50.0;  // 50 Pa off: 50 / max(2e4, p) of the mean stress
    EXPECT_EQ(track_controls(leg, c, model.dt, state_at(s, n), e), -1);
  }
  EXPECT_TRUE(std::isnan(e.error[0]));  // driven: no control
  EXPECT_NEAR(e.error[1], 0.001, 1e-12);
  EXPECT_NEAR(e.sustained[1], 0.001, 1e-9);
  const double p = (2.0 * kP + kP * 1.001 + kP) / 3.0;
  EXPECT_NEAR(e.error[3], 50.0 / p, 1e-12);
  EXPECT_EQ(control_kind(e.mode[3], 3), "shear_stress");
  EXPECT_NEAR(e.worst("shear_stress"), 50.0 / p, 1e-12);
  EXPECT_FALSE(e.failed[1] || e.failed[3]);
  EXPECT_EQ(control_failures({e}).size(), 0u);
  EXPECT_LT(control_error_maxima({e}).over_tolerance, 1.0);
}

TEST(ControlVerdict, ASlipSpikePassesALagThatStaysFails) {
  const Model model = unit_model();
  const Leg leg = stress_leg();
  const LegChecks c(leg, model);
  ControlErrors spike;  // 5 % for 20 steps in a span of 1000, then back on target
  for (std::int64_t n = c.settle; n < c.settle + 3 * c.span; ++n) {
    const bool in_spike = n >= c.settle + c.span && n < c.settle + c.span + 20;
    EXPECT_EQ(track_controls(leg, c, model.dt, state_at(held_stresses(in_spike ? 0.05 : 0.0), n), spike), -1);
  }
  EXPECT_NEAR(spike.error[1], 0.05, 1e-12);  // the worst step is reported...
  EXPECT_LT(spike.sustained[1], kServoTolerance);  // ...but the span's average holds
  EXPECT_FALSE(spike.failed[1]);
  ControlErrors lag;  // 0.8 % that stays
  int failed = -1;
  std::int64_t n = c.settle;
  for (; failed < 0 && n < c.settle + 3 * c.span; ++n)
    failed = track_controls(leg, c, model.dt, state_at(held_stresses(0.008), n), lag);
  EXPECT_EQ(failed, 1);
  EXPECT_EQ(n - c.settle, c.span);  // judged once a whole span was checked
  EXPECT_TRUE(lag.failed[1]);
  EXPECT_NEAR(lag.target_at_failure[1], kP, 1e-9);
  EXPECT_NEAR(lag.reached_at_failure[1], 1.008 * kP, 1e-6);
  EXPECT_GT(control_error_maxima({lag}).over_tolerance, 1.0);
}

// An error that swings about the target (a target that turns faster than the servo follows) crosses zero at
// every period, so no run of steps stays out of tolerance; its average does not.
TEST(ControlVerdict, AnErrorSwingingAboutTheTargetFails) {
  const Model model = unit_model();
  const Leg leg = stress_leg();
  const LegChecks c(leg, model);
  ControlErrors e;
  int failed = -1;
  for (std::int64_t n = c.settle; failed < 0 && n < c.settle + 2 * c.span; ++n)
    failed = track_controls(leg, c, model.dt, state_at(held_stresses(0.02 * std::sin(0.3 * n)), n), e);
  EXPECT_EQ(failed, 1);
}

// A leg that ends before a whole span (an adaptive leg that outran its servo) is judged at its end on what it ran.
TEST(ControlVerdict, AShortLegIsJudgedAtItsEnd) {
  const Model model = unit_model();
  const Leg leg = stress_leg();
  const LegChecks c(leg, model);
  ControlErrors e;
  for (std::int64_t n = c.settle; n < c.settle + 79; ++n)
    EXPECT_EQ(track_controls(leg, c, model.dt, state_at(held_stresses(0.5), n), e), -1);
  EXPECT_FALSE(e.failed[1]);
  EXPECT_EQ(judge_leg_end(state_at(held_stresses(0.5), c.settle + 79), e), 1);
  EXPECT_NEAR(e.sustained[1], 0.5, 1e-9);
  EXPECT_NEAR(e.reached_at_failure[1], 1.5 * kP, 1e-6);
  // Nothing checked (a leg shorter than its settle window): nothing judged.
  ControlErrors none;
  EXPECT_EQ(judge_leg_end(state_at(held_stresses(0.5), 10), none), -1);
  EXPECT_TRUE(std::isnan(none.sustained[1]));
}

TEST(ControlVerdict, RecordsRoundTripThroughJsonAndNameTheirComponent) {
  const Model model = unit_model();
  const Leg leg = stress_leg();
  const LegChecks c(leg, model);
  ControlErrors e;
  for (std::int64_t n = c.settle; n < c.settle + c.span + 5; ++n)
    track_controls(leg, c, model.dt, state_at(held_stresses(0.01), n), e);
  const nlohmann::json j = to_json(e);
  ASSERT_EQ(j["axes"].size(), 6u);
  EXPECT_EQ(j["axes"][3]["name"], "x12");
  EXPECT_EQ(j["axes"][3]["kind"], "shear_stress");
  EXPECT_EQ(j["axes"][1]["kind"], "stress");
  EXPECT_TRUE(j["axes"][1]["failed"].get<bool>());
  const ControlErrors back = control_errors_from_json(nlohmann::json::parse(j.dump()));
  EXPECT_EQ(to_json(back).dump(), j.dump());  // every field, the running average included (a resume goes on from it)
  const std::vector<ControlFailureRecord> f = control_failures({ControlErrors{}, e});
  ASSERT_EQ(f.size(), 1u);
  EXPECT_EQ(f[0].leg, 1u);
  EXPECT_EQ(component_name(f[0].component), "x2");
  EXPECT_EQ(f[0].tolerance, kServoTolerance);
  const std::vector<std::string> w = control_warnings("ttc", {ControlErrors{}, e});
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("axis x2"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("target 1e+05 Pa"), std::string::npos) << w[0];
}

TEST(ControlVerdict, MaximaKeepEachUnitAndNaNWhenNothingWasMeasured) {
  for (const auto& errors : {std::vector<ControlErrors>{}, std::vector<ControlErrors>{{}, {}}}) {
    const ControlErrorMaxima m = control_error_maxima(errors);
    EXPECT_TRUE(std::isnan(m.servo) && std::isnan(m.b) && std::isnan(m.volume) && std::isnan(m.over_tolerance));
  }
  ControlErrors b;
  b.mode[1] = AxisMode::B, b.error[1] = 0.02, b.sustained[1] = 0.008;  // b is absolute: never mixed into the servo's
  ControlErrors stress;
  stress.mode[2] = AxisMode::Stress, stress.error[2] = 0.003, stress.sustained[2] = 0.001;
  const ControlErrorMaxima m = control_error_maxima({stress, b});
  EXPECT_EQ(m.servo, 0.003);
  EXPECT_EQ(m.b, 0.02);
  EXPECT_DOUBLE_EQ(m.over_tolerance, 0.8);  // the sustained b, 0.008 of 0.01
}

}  // namespace
}  // namespace celldem
