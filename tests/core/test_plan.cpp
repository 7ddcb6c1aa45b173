// What a deck implies (solver/core/plan.hpp): the mean contact under the confining stress, its Hertz overlap and
// the linear stiffnesses equivalent there, and the material's moduli, against hand calculations.
#include <algorithm>
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <string>

#include "core/plan.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

// A deck of spheres of 2 mm and 4 mm (mean d = 3 mm), density 2650, the preparation at 50 kPa and a test whose
// stress end (200 kPa) is the largest stress it names.
Deck mean_contact_deck(NormalModel normal, TangentialModel tangential) {
  Deck d = testing::model_deck(1e6, 5e5, 1e-7, 2650.0);
  d.sample.diameters = {2e-3, 4e-3};
  d.sample.grid_spacing = 5e-3;
  d.contact.normal = normal;
  d.contact.tangential = tangential;
  if (normal != NormalModel::Linear || tangential != TangentialModel::LinearHistory) {
    d.contact.youngs_modulus = 7e10;
    d.contact.poisson_ratio = 0.25;
  }
  if (normal != NormalModel::Linear) d.contact.kn = 0.0;
  if (tangential != TangentialModel::LinearHistory) d.contact.kt = 0.0;
  d.prepare->target_pressure = 5e4;
  TestDef t;
  t.name = "t";
  Leg leg;
  leg.axes = {AxisControl{AxisMode::StrainIncrement, 1e-6}, AxisControl{AxisMode::Stress, 1e5},
              AxisControl{AxisMode::Stress, 1e5}};
  leg.end = {.kind = LegEndKind::Stress, .axis = 0, .value = 2e5};
  t.legs = {leg};
  d.tests = {t};
  return d;
}

// The moduli of two spheres of one material: E* = E / (2 (1 - nu^2)), G* = E / (4 (2 - nu) (1 + nu)).
TEST(Plan, MaterialModuli) {
  const Deck d = mean_contact_deck(NormalModel::Hertz, TangentialModel::Mindlin);
  EXPECT_TRUE(has_material_moduli(d.contact));
  EXPECT_DOUBLE_EQ(d.contact.effective_modulus(), 7e10 / (2.0 * 0.9375));            // 3.7333e10 Pa
  EXPECT_DOUBLE_EQ(d.contact.effective_shear_modulus(), 7e10 / (4.0 * 1.75 * 1.25));  // 8e9 Pa
  EXPECT_TRUE(has_material_moduli(mean_contact_deck(NormalModel::Linear, TangentialModel::MindlinRescale).contact));
  EXPECT_TRUE(has_material_moduli(mean_contact_deck(NormalModel::Hertz, TangentialModel::LinearHistory).contact));
  EXPECT_FALSE(has_material_moduli(mean_contact_deck(NormalModel::Linear, TangentialModel::LinearHistory).contact));
}

// The confining stress is the largest the deck names (a stress end included); the mean contact force follows
// from the mean stress of N_c = Z N / 2 contacts in V, p = N_c <f l> / (3 V) = Z N <f l> / (6 V), with branch
// length l = d and N = phi V / (pi d^3 / 6) spheres: f = pi d^2 p / (Z phi), at Z phi = 3.6.
TEST(Plan, MeanContactForceFromTheConfiningStress) {
  const Deck d = mean_contact_deck(NormalModel::Hertz, TangentialModel::Mindlin);
  EXPECT_EQ(largest_deck_stress(d), 2e5);
  // Z phi of a dense random packing lies between the isostatic frictional one at random loose packing
  // (Z = 4, phi = 0.55) and the frictionless one at random close packing (Z = 6, phi = 0.64).
  EXPECT_GE(kMeanContactZPhi, 4.0 * 0.55);
  EXPECT_LE(kMeanContactZPhi, 6.0 * 0.64);
  const double diameter = 3e-3, p = 2e5;
  EXPECT_DOUBLE_EQ(mean_diameter(d.sample), diameter);
  // The relation solved for f, with the volume of the spheres N pi d^3 / 6 = phi V (Z phi = 6 x 0.6 = 3.6).
  const double z = 6.0, phi = 0.6, volume = 1.0;
  const double n = phi * volume / (M_PI * diameter * diameter * diameter / 6.0);
  const double f = 6.0 * volume * p / (z * n * diameter);
  EXPECT_NEAR(mean_contact_force(d.sample, p), f, 1e-12 * f);
  EXPECT_NEAR(f, 1.5707963267948966, 1e-12);  // pi (3e-3)^2 2e5 / 3.6 = pi/2 N
}

// Hertz: F = 4/3 E* sqrt(R*) delta^(3/2), so delta = (3 F / (4 E* sqrt(R*)))^(2/3); checked by putting it back.
TEST(Plan, HertzOverlapInvertsTheHertzForce) {
  const Deck d = mean_contact_deck(NormalModel::Hertz, TangentialModel::Mindlin);
  const double e_star = 7e10 / 1.875, r_eff = 0.75e-3, force = 2.0;
  const double delta = hertz_overlap(d.contact, force, r_eff);
  EXPECT_NEAR(4.0 / 3.0 * e_star * std::sqrt(r_eff) * std::pow(delta, 1.5), force, 1e-12 * force);
  // By hand: 3 x 2 / (4 x 3.7333e10 x sqrt(7.5e-4)) = 6 / 4.08966e9 = 1.46711e-9, to the 2/3: 1.29115e-6 m.
  EXPECT_NEAR(delta, 1.29115e-6, 1e-4 * 1.29115e-6);
  EXPECT_EQ(normal_overlap(d.contact, force, r_eff), delta);
  // The linear law: F / kn.
  const Deck linear = mean_contact_deck(NormalModel::Linear, TangentialModel::LinearHistory);
  EXPECT_EQ(normal_overlap(linear.contact, force, r_eff), force / 1e6);
}

TEST(Plan, MeanContactOfAHertzMindlinDeck) {
  const Deck d = mean_contact_deck(NormalModel::Hertz, TangentialModel::Mindlin);
  const std::optional<MeanContact> m = mean_contact(d);
  ASSERT_TRUE(m.has_value());
  const double p = 2e5, diameter = 3e-3, r_eff = diameter / 4.0, force = M_PI * diameter * diameter * p / 3.6;
  const double e_star = 7e10 / 1.875, g_star = 8e9;
  const double delta = std::pow(3.0 * force / (4.0 * e_star * std::sqrt(r_eff)), 2.0 / 3.0);
  const double a = std::sqrt(r_eff * delta);
  EXPECT_EQ(m->confining_stress, p);
  EXPECT_DOUBLE_EQ(m->mean_diameter, diameter);
  EXPECT_DOUBLE_EQ(m->effective_radius, r_eff);
  EXPECT_NEAR(m->force, force, 1e-14 * force);
  EXPECT_NEAR(m->overlap, delta, 1e-12 * delta);
  EXPECT_NEAR(m->secant_normal_stiffness, force / delta, 1e-12 * force / delta);
  // The secant stiffness of Hertz is 2/3 of its tangent stiffness 2 E* a at the same overlap.
  EXPECT_NEAR(m->secant_normal_stiffness, 2.0 / 3.0 * 2.0 * e_star * a, 1e-12 * m->secant_normal_stiffness);
  EXPECT_NEAR(m->contact_radius, a, 1e-12 * a);
  EXPECT_NEAR(m->mindlin_tangential_stiffness, 8.0 * g_star * a, 1e-12 * 8.0 * g_star * a);
}

TEST(Plan, MeanContactOfALinearDeckAndOfADeckWithoutStress) {
  Deck d = mean_contact_deck(NormalModel::Linear, TangentialModel::LinearHistory);
  const std::optional<MeanContact> m = mean_contact(d);
  ASSERT_TRUE(m.has_value());
  const double force = M_PI * 9e-6 * 2e5 / 3.6;
  EXPECT_NEAR(m->overlap, force / 1e6, 1e-14 * force / 1e6);
  EXPECT_NEAR(m->secant_normal_stiffness, 1e6, 1e-6);  // the linear spring itself
  EXPECT_EQ(m->mindlin_tangential_stiffness, 0.0);     // no E and nu
  d.tests.clear();
  d.prepare->target_pressure = 0.0;
  EXPECT_FALSE(mean_contact(d).has_value());
}

// The default reference overlap is the normal law's overlap under 10 x the mean contact force at 3 x the
// confining stress, between the two largest spheres.
TEST(Plan, DefaultReferenceOverlapFromTheMeanContactForce) {
  const Deck d = mean_contact_deck(NormalModel::Hertz, TangentialModel::Mindlin);
  const double force = 10.0 * mean_contact_force(d.sample, 3.0 * 2e5);
  EXPECT_EQ(default_reference_overlap(d), hertz_overlap(d.contact, force, 1e-3));  // R* of two 4 mm spheres
}


// The time_step key's meaning (core/deck_schema.hpp, printed by `celldem schema` and in docs/deck.md) names the
// bounds in words and numbers, since the key table cannot include core/plan: every bound of kTimeStepBounds must
// be there, as "above|below [the stability limit] F t_c" in the refused or the warned part, with its fraction,
// and nothing else.
TEST(TimeStepBounds, TheKeyTableNamesEachBoundWithItsFraction) {
  const std::string meaning(keys::time_step.meaning);
  const std::size_t warned = meaning.find("; warned");
  ASSERT_NE(warned, std::string::npos) << meaning;
  const std::regex phrase(R"((above|below) (the stability limit )?(([0-9.]+(e[-+]?[0-9]+)?) )?t_c)");
  std::vector<TimeStepBound> named;
  for (auto m = std::sregex_iterator(meaning.begin(), meaning.end(), phrase); m != std::sregex_iterator(); ++m)
    named.push_back({"", static_cast<std::size_t>(m->position()) < warned, (*m)[1] == "above",
                     (*m)[4].matched ? std::stod((*m)[4]) : 1.0, ""});
  ASSERT_EQ(named.size(), kTimeStepBounds.size()) << meaning;
  for (const TimeStepBound& b : kTimeStepBounds) {
    bool found = false;
    for (const TimeStepBound& n : named)
      found |= n.refuse == b.refuse && n.above == b.above && n.fraction == b.fraction;
    EXPECT_TRUE(found) << b.name << " (" << (b.refuse ? "refused " : "warned ") << (b.above ? "above " : "below ")
                       << b.fraction << " t_c) is not in: " << meaning;
  }
}

// The rows a stage writes, by its rule followed step by step: the first at step 0, one at every
// output_interval-th step, one at each leg's end unless the interval has just written it. Rows per leg.
std::vector<std::int64_t> rows_by_stepping(const std::vector<std::int64_t>& leg_steps, std::int64_t interval) {
  std::vector<std::int64_t> rows;
  std::int64_t step = 0, last_row = 0;
  for (std::size_t k = 0; k < leg_steps.size(); ++k) {
    std::int64_t n = k == 0 ? 1 : 0;
    for (std::int64_t j = 0; j < leg_steps[k]; ++j)
      if (++step % interval == 0) ++n, last_row = step;
    if (last_row != step) ++n, last_row = step;
    rows.push_back(n);
  }
  return rows;
}

// The preparation's own legs, listed as a test's: an isotropic compression to a solid fraction (its steps by
// following the solid fraction step by step: every axis at strain n d after n steps), a strain leg from where
// that left the axis, a leg of fixed steps and the servo to equilibrium (min_steps to max_steps; its rows and
// those after it unknown); each leg's driving increment and rate, servo cap and rows.
TEST(Plan, PreparationLegsListedAsATestsAreFromWhereTheyStart) {
  Deck d = testing::model_deck(1e6, 1e6, 2e-6, 2650.0);
  d.prepare->output_interval = 300;
  d.servo.max_strain_increment = 4e-5;
  d.servo.max_strain_increment_given = true;
  Leg fast, shear, hold, servo;
  std::fill_n(fast.axes.begin(), 3, AxisControl{AxisMode::StrainIncrement, 1e-4});
  fast.end = {.kind = LegEndKind::SolidFraction, .value = 0.6};
  shear.axes = {AxisControl{AxisMode::StrainRate, 5.0}, AxisControl{AxisMode::StrainIncrement, 0.0},
                AxisControl{AxisMode::Stress, 1e5}};
  shear.end = {.kind = LegEndKind::Strain, .axis = 0, .value = 0.25};
  std::fill_n(hold.axes.begin(), 3, AxisControl{AxisMode::Stress, 1e5});
  hold.end = {.kind = LegEndKind::Steps, .steps = 450};
  std::fill_n(servo.axes.begin(), 3, AxisControl{AxisMode::Stress, 1e5});
  servo.end = {.kind = LegEndKind::Equilibrium, .max_steps = 7000};
  d.prepare->legs = {fast, shear, hold, servo};
  d.prepare->default_legs = false;

  const double start = 0.3;  // a loaded state's solid fraction
  std::int64_t n_fast = 0;
  while (start / std::pow(1.0 - static_cast<double>(n_fast) * 1e-4, 3) < 0.6) ++n_fast;
  const double e1 = static_cast<double>(n_fast) * 1e-4;
  const std::int64_t n_shear = std::llround((0.25 - e1) / (5.0 * 2e-6));
  ASSERT_GT(n_shear, 1000);
  const PreparationPlan plan = plan_preparation(d, start);
  ASSERT_EQ(plan.listed.size(), 4u);
  EXPECT_EQ(plan.skipped, 0);
  const std::vector<std::int64_t> exact = {n_fast, n_shear, 450};
  const std::vector<std::int64_t> rows = rows_by_stepping(exact, 300);
  for (std::size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(plan.listed[k].steps.low, exact[k]) << k;
    EXPECT_EQ(plan.listed[k].steps.high, exact[k]) << k;
    EXPECT_EQ(plan.listed[k].rows, rows[k]) << k;
  }
  EXPECT_EQ(plan.listed[3].steps.low, d.prepare->equilibrium.min_steps);
  EXPECT_EQ(plan.listed[3].steps.high, 7000);
  EXPECT_EQ(plan.listed[3].rows, -1);
  EXPECT_EQ(preparation_steps(d, start).low, n_fast + n_shear + 450 + d.prepare->equilibrium.min_steps);

  EXPECT_EQ(plan.listed[0].driving_increment, 1e-4);
  EXPECT_DOUBLE_EQ(plan.listed[0].driving_rate, 1e-4 / 2e-6);
  EXPECT_FALSE(plan.listed[0].servo);
  EXPECT_DOUBLE_EQ(plan.listed[1].driving_increment, 5.0 * 2e-6);
  EXPECT_TRUE(plan.listed[1].servo);
  EXPECT_EQ(plan.listed[1].servo_cap, 4e-5);  // the deck's cap
  EXPECT_EQ(plan.listed[3].driving_increment, 0.0);

  // The fast leg's length follows from where the stage starts (its rows with it); unknown steps make the rows
  // of every later leg unknown, a test's as well.
  EXPECT_GT(plan_preparation(d, 0.2).listed[0].steps.low, n_fast);
  TestDef t;
  t.name = "t";
  t.output_interval = 300;
  Leg ratio = shear;
  ratio.end = {.kind = LegEndKind::Ratio, .value = 1.5};
  t.legs = {hold, ratio, hold};
  const TestPlan tp = plan_test(d, t);
  ASSERT_EQ(tp.legs.size(), 3u);
  EXPECT_EQ(tp.legs[0].rows, rows_by_stepping({450}, 300)[0]);
  EXPECT_EQ(tp.legs[1].rows, -1);
  EXPECT_EQ(tp.legs[2].rows, -1);
  EXPECT_EQ(tp.legs[2].steps.high, -1);  // program_leg_steps: every leg after an unknown one
  EXPECT_EQ(tp.rows, -1);
  t.legs = {shear, hold};  // every length known: the test's rows are the legs', leg ends included
  const TestPlan known = plan_test(d, t);
  std::int64_t sum = 0;
  for (const std::int64_t r : rows_by_stepping({std::llround(0.25 / 1e-5), 450}, 300)) sum += r;
  EXPECT_EQ(known.rows, sum);
  // A leg that ends on the strain of an axis an earlier leg held by its servo starts where only running tells
  // (the servo moved the axis): its length is not known ahead.
  t.legs = {hold, shear, hold};
  EXPECT_EQ(plan_test(d, t).legs[1].steps.high, -1);
}

// A leg that ends on the shear strain of a shear axis it drives by its strain is known ahead like a normal strain
// leg: g = g(leg start) + n d, each leg from where the previous one left the axis (a leg between that does not
// name it keeps its tilt); after a leg that holds the axis at a shear stress only running tells.
TEST(Plan, ShearStrainEndsAreKnownAheadFromWhereTheLegStarts) {
  Deck d = testing::model_deck(1e6, 1e6, 2e-6, 2650.0);
  Leg forward, hold, back, at_stress;
  const std::array<AxisControl, 3> axes = {AxisControl{AxisMode::StrainIncrement, 0.0}, AxisControl{AxisMode::Stress, 1e5},
                                           AxisControl{AxisMode::StrainIncrement, 0.0}};
  for (Leg* leg : {&forward, &hold, &back, &at_stress}) std::copy(axes.begin(), axes.end(), leg->axes.begin());
  forward.axes[3 + 0] = AxisControl{AxisMode::StrainIncrement, 2e-6};
  forward.end = {.kind = LegEndKind::Strain, .axis = 3, .value = 0.01};
  hold.end = {.kind = LegEndKind::Steps, .steps = 300};
  back.axes[3 + 0] = AxisControl{AxisMode::StrainRate, -0.5};  // -1e-6 per step at dt = 2e-6
  back.end = {.kind = LegEndKind::Strain, .axis = 3, .value = 0.004};
  at_stress.axes[3 + 0] = AxisControl{AxisMode::Stress, 0.0};
  at_stress.end = {.kind = LegEndKind::Steps, .steps = 100};
  std::vector<double> from;
  const std::vector<std::int64_t> steps = program_leg_steps({forward, hold, back}, 2e-6, &from);
  EXPECT_EQ(steps, (std::vector<std::int64_t>{5000, 300, 6000}));
  EXPECT_EQ(from[2], 0.01);
  EXPECT_EQ(leg_steps(back, 2e-6, 0.01), 6000);
  // Capped by max_steps like a normal strain end.
  Leg capped = forward;
  capped.end.max_steps = 1234;
  EXPECT_EQ(leg_steps(capped, 2e-6, 0.0), 1234);
  // After a leg at a shear stress the axis's strain is unknown; other legs' lengths are still known.
  const std::vector<std::int64_t> after = program_leg_steps({forward, at_stress, back}, 2e-6, &from);
  EXPECT_EQ(after, (std::vector<std::int64_t>{5000, 100, -1}));
  EXPECT_TRUE(std::isnan(from[2]));
  // The test's plan lists them with their rows.
  TestDef t;
  t.name = "shear";
  t.output_interval = 1000;
  t.legs = {forward, hold, back};
  const TestPlan p = plan_test(d, t);
  EXPECT_EQ(p.steps, 5000 + 300 + 6000);
  EXPECT_EQ(p.strain_per_step, 2e-6);  // the first leg's end axis, the shear axis
  // An adaptive leg's steps lie between its fastest and its slowest rate; the next leg starts where it ends (its
  // end strain), so its length is still known; the test's total and rows are known only by running.
  t.legs[0].adaptive = AdaptiveRate{.min_factor = 0.5, .max_factor = 3.0};
  const TestPlan adaptive = plan_test(d, t);
  EXPECT_EQ(adaptive.legs[0].steps.low, 1667);  // ceil(5000 / 3)
  EXPECT_EQ(adaptive.legs[0].steps.high, 10000);
  EXPECT_TRUE(adaptive.legs[2].steps.exact());
  EXPECT_EQ(adaptive.legs[2].steps.low, 6000);
  EXPECT_EQ(adaptive.steps, -1);
  EXPECT_EQ(adaptive.rows, -1);
}

}  // namespace
}  // namespace celldem

namespace celldem {
namespace {

// The inertial number's rate: the largest strain rate of a driven axis, a shear axis's engineering shear rate
// included (a simple shear has no driven normal axis), and the probes' steps.
// The inertial number's rate is one deviatoric scale, sqrt(3/2 e':e') of the imposed rates: |e1-dot| exactly for
// one driven axis (the axial tests keep their scale bit for bit), (sqrt 3 / 2) g-dot for a shear, every driven
// component counted together, and the largest normal rate of an isotropic drive.
TEST(Plan, InertialRateIsOneDeviatoricScale) {
  for (const double e1 : {0.2, -0.2, 2e-7 / 1e-6, 1.0 / 3.0, 9.98e-7 / 3e-6, 1e-3, 7.3})
    EXPECT_EQ(inertial_strain_rate({e1, 0.0, 0.0, 0.0, 0.0, 0.0}), std::abs(e1)) << e1;  // exactly
  EXPECT_EQ(inertial_strain_rate({0.0, 0.0, 0.2, 0.0, 0.0, 0.0}), 0.2);
  EXPECT_DOUBLE_EQ(inertial_strain_rate({0.0, 0.0, 0.0, 0.2, 0.0, 0.0}), std::sqrt(3.0) / 2.0 * 0.2);  // simple shear
  EXPECT_DOUBLE_EQ(inertial_strain_rate({0.2, -0.2, 0.0, 0.0, 0.0, 0.0}), std::sqrt(3.0) * 0.2);
  EXPECT_DOUBLE_EQ(inertial_strain_rate({0.2, -0.1, -0.1, 0.0, 0.0, 0.0}), 0.3);  // isochoric axial: 3/2 e1
  EXPECT_EQ(inertial_strain_rate({0.3, 0.3, 0.3, 0.0, 0.0, 0.0}), 0.3);  // isotropic: no deviatoric part
  EXPECT_EQ(inertial_strain_rate({0.0, 0.0, 0.0, 0.0, 0.0, 0.0}), 0.0);
  // Frame: a pure shear e11 = -e22 = g/2 is the simple shear g rotated by 45 degrees, the same scale.
  EXPECT_DOUBLE_EQ(inertial_strain_rate({0.1, -0.1, 0.0, 0.0, 0.0, 0.0}), inertial_strain_rate({0.0, 0.0, 0.0, 0.2, 0.0, 0.0}));
}

TEST(Plan, LoadingRateIsTheDeviatoricScaleAndProbesCountTheirSteps) {
  Deck d = testing::model_deck(1e6, 1e6, 2e-6, 2650.0);
  TestDef t;
  t.name = "dss";
  Leg leg;
  leg.axes = {AxisControl{AxisMode::StrainIncrement, 0.0}, AxisControl{AxisMode::Stress, 1e5},
              AxisControl{AxisMode::StrainIncrement, 0.0}};
  leg.axes[3 + 0] = AxisControl{AxisMode::StrainIncrement, 4e-6};
  leg.end = {.kind = LegEndKind::Steps, .steps = 100};
  Leg faster = leg;
  faster.axes[3 + 0] = AxisControl{AxisMode::Held};
  faster.axes[3 + 2] = AxisControl{AxisMode::StrainRate, -3.0};
  t.legs = {leg};
  EXPECT_DOUBLE_EQ(loading_rate(d, t), std::sqrt(3.0) / 2.0 * 4e-6 / 2e-6);  // a simple shear's g-dot
  t.legs = {leg, faster};
  EXPECT_DOUBLE_EQ(loading_rate(d, t), std::sqrt(3.0) / 2.0 * 3.0);  // the faster leg
  t.legs[1].axes[0] = AxisControl{AxisMode::StrainRate, 5.0};  // a normal axis counts with the shear
  EXPECT_DOUBLE_EQ(loading_rate(d, t), std::sqrt(25.0 + 0.75 * 9.0));
  Leg axial = leg;
  axial.axes[3 + 0] = AxisControl{AxisMode::Held};
  axial.axes[0] = AxisControl{AxisMode::StrainIncrement, -2e-7};
  t.legs = {axial};
  EXPECT_EQ(loading_rate(d, t), 2e-7 / 2e-6);  // an axial test: |e1-dot|, exactly as before

  EXPECT_EQ(plan_probes(t).steps(), 0);
  ProbeDef probes;
  probes.at = {"peak"};
  probes.at_e1 = {0.01, 0.02};
  probes.directions = 8;
  probes.magnitudes = {1e3, 2e3};
  probes.steps = 100;
  probes.hold_steps = 50;
  t.probes = probes;
  const ProbePlan p = plan_probes(t);
  EXPECT_EQ(p.points, 3);
  EXPECT_EQ(p.probes_per_point, 1 + 8 * 2);
  // Each point: a rest of at most rest_max_steps (whole windows of one probe's 300 steps), the elastic check's
  // seven probes and the set's.
  const std::int64_t rest = (probes.rest_max_steps + 299) / 300 * 300;
  EXPECT_EQ(p.rest_steps_per_point, rest);
  EXPECT_EQ(p.steps(), 3 * (rest + (17 + 7) * 300));
  t.probes->kind = ProbeKind::Strain;
  EXPECT_EQ(plan_probes(t).probes_per_point, 1 + 6 * 2);
  EXPECT_EQ(plan_probes(t).check_probes_per_point, 0);  // a strain set is its own elastic check
}

}  // namespace
}  // namespace celldem
