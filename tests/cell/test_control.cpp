// Mixed control of the periodic cell (solver/cell/control.hpp): strain-driven axes follow their exact
// engineering strain, the velocity gradient is the midpoint one, the servo law does what its comment says,
// and on a real packing the servo holds a stress-controlled axis at its target while another is compressed.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <string>

#include "contact/contact_forces.hpp"
#include "contact_stress.hpp"
#include "helpers.hpp"
#include "core/deck.hpp"
#include "io/state_file.hpp"
#include "neighbor/neighbor_list.hpp"
#include "run/runner.hpp"
#include "step.hpp"

namespace celldem {
namespace {

using testing::model_deck;
using testing::set_shear;

State cell_state(const Mat3& h) {
  State s;
  s.cell.h = h;
  s.control.reference.head<3>() = h.diagonal();
  s.control.reference_volume = h.determinant();
  return s;
}

// The coupled targets, against the stresses they must reproduce by hand (s1 = 160 unless said).
TEST(Control, StressTargetsOfBAndMeanStress) {
  const AxisControl driven{AxisMode::StrainIncrement, 1e-6};
  struct Case {
    const char* what;
    AxisControl x2, x3;
    double s1, t2, t3;
  };
  const AxisControl mean{AxisMode::MeanStress, 100.0};
  const Case cases[] = {
      {"b 0.5, fixed minor 40: 40 + 0.5 (160 - 40)", {AxisMode::B, 0.5}, {AxisMode::Stress, 40.0}, 160, 100, 40},
      {"b 0.5 and p 100: s3 = (300 - 1.5 160) / 1.5", {AxisMode::B, 0.5}, mean, 160, 100, 40},
      {"b 0 at p 100 (compression): s2 = s3 = (300 - 160) / 2", {AxisMode::B, 0.0}, mean, 160, 70, 70},
      {"b 1 at p 100 (extension): s2 = s1", {AxisMode::B, 1.0}, mean, 130, 130, 40},
      {"two mean_stress axes share 3p - s1", mean, mean, 160, 70, 70},
      {"a mean_stress axis beside a fixed one takes the rest", {AxisMode::Stress, 50.0}, mean, 160, 50, 90},
  };
  for (const Case& c : cases) {
    const Vec3 t = stress_targets({driven, c.x2, c.x3}, Vec3(c.s1, 0.0, 0.0), 0.0);
    EXPECT_TRUE(std::isnan(t[0])) << c.what;
    EXPECT_DOUBLE_EQ(t[1], c.t2) << c.what;
    EXPECT_DOUBLE_EQ(t[2], c.t3) << c.what;
    if (c.x3.mode == AxisMode::MeanStress) {
      EXPECT_DOUBLE_EQ((c.s1 + t[1] + t[2]) / 3.0, 100.0) << c.what;
    }
  }
}

// Constant-volume axes keep det h at the leg's start volume, with equal strain increments on two of them;
// on a sheared (non-diagonal) cell too.
TEST(Control, ConstantVolumeAxesHoldTheVolume) {
  const Model model = make_model(model_deck(1e4, 1e4, 1e-3), {});
  for (const Mat3& h0 : {Mat3(Vec3(2.0, 3.0, 4.0).asDiagonal()),
                         (Mat3() << 2.0, 0.3, -0.1, 0.0, 3.0, 0.2, 0.0, 0.0, 4.0).finished()}) {
    State s = cell_state(h0);
    begin_stage(s);
    const double v0 = s.cell.volume();
    const AxisControl cv{AxisMode::ConstantVolume, 0.0};
    Loading two{{AxisControl{AxisMode::StrainIncrement, 1e-4}, cv, cv}, 0.0};
    for (int k = 0; k < 500; ++k) advance_cell(model, two, s);
    EXPECT_NEAR(s.cell.volume() / v0 - 1.0, 0.0, 1e-13);
    EXPECT_NEAR(axis_strains(s)[0], 0.05, 1e-14);
    EXPECT_NEAR(s.cell.h(1, 1) / h0(1, 1), s.cell.h(2, 2) / h0(2, 2), 1e-13);  // equal lateral strains
    // One constant-volume axis beside a fixed one, in a later leg that starts from the present cell.
    begin_leg(s, 1);
    const double v1 = s.cell.volume();
    Loading one{{AxisControl{AxisMode::StrainIncrement, -1e-4}, AxisControl{AxisMode::StrainIncrement, 0.0}, cv}, 0.0};
    for (int k = 0; k < 200; ++k) advance_cell(model, one, s);
    EXPECT_NEAR(s.cell.volume() / v1 - 1.0, 0.0, 1e-13);
    EXPECT_NEAR(axis_strains(s)[0], 0.05 - 0.02, 1e-14);  // the leg continues from the present strain
  }
}

// Advances the cell `steps` times, checking each step's velocity gradient: hdot = L h_mid over the step.
void advance_checking_velocity_gradient(const Model& model, const Loading& loading, State& s, int steps) {
  for (int k = 0; k < steps; ++k) {
    const Mat3 before = s.cell.h;
    advance_cell(model, loading, s);
    const Mat3 hdot = (s.cell.h - before) / model.dt;
    EXPECT_NEAR((s.cell.velocity_gradient * 0.5 * (s.cell.h + before) - hdot).norm(), 0.0, 1e-12);
  }
}

TEST(Control, StrainIncrementAndRateFollowExactEngineeringStrain) {
  const double dt = 1e-3;
  const Model model = make_model(model_deck(1e4, 1e4, dt), {});
  const Mat3 h0 = (Mat3() << 2.0, 0.3, -0.1, 0.0, 3.0, 0.2, 0.0, 0.0, 4.0).finished();
  State s = cell_state(h0);
  const Loading loading{{AxisControl{AxisMode::StrainIncrement, 1e-4}, AxisControl{AxisMode::StrainRate, -0.5},
                         AxisControl{AxisMode::StrainIncrement, 0.0}},
                        0.0};
  const int steps = 1000;
  advance_checking_velocity_gradient(model, loading, s, steps);
  EXPECT_EQ(s.control.leg_steps, steps);
  EXPECT_DOUBLE_EQ(s.cell.h(0, 0), 2.0 * (1.0 - steps * 1e-4));        // compression 10 %
  EXPECT_DOUBLE_EQ(s.cell.h(1, 1), 3.0 * (1.0 + steps * 0.5 * dt));   // extension 50 %
  EXPECT_EQ(s.cell.h(2, 2), 4.0);
  for (int r = 0; r < 3; ++r)  // off-diagonal terms are held
    for (int c = 0; c < 3; ++c)
      if (r != c) { EXPECT_EQ(s.cell.h(r, c), h0(r, c)); }
  const Vec3 e = axis_strains(s);
  EXPECT_NEAR(e[0], 0.1, 1e-14);
  EXPECT_NEAR(e[1], -0.5, 1e-14);
  EXPECT_EQ(e[2], 0.0);
  // For a diagonal cell the gradient is diagonal: L_kk = (h1 - h0) / (dt (h1 + h0) / 2).
  State d = cell_state(Mat3::Identity() * 2.0);
  advance_cell(model, loading, d);
  EXPECT_NEAR(d.cell.velocity_gradient(0, 0), (2.0 * (1 - 1e-4) - 2.0) / (dt * (2.0 * (1 - 1e-4) + 2.0) / 2), 1e-12);
  EXPECT_NEAR(d.cell.velocity_gradient(0, 1), 0.0, 1e-15);
}

// One servo step by hand: err = target - s_kk, de = (gain err + integral_gain (I + err)) / K, h_kk *= 1 - de.
TEST(Control, ServoStepFollowsItsLaw) {
  Deck deck = model_deck(1e4, 1e4, 1e-3);
  deck.servo = ServoDef{0.05, 0.002, 1e-3};
  const Model model = make_model(deck, {});
  const double target = 1.0e5, K = 2.0e8;
  const Loading loading{{AxisControl{AxisMode::Stress, target}, AxisControl{AxisMode::Stress, target},
                         AxisControl{AxisMode::StrainIncrement, 0.0}},
                        0.0};
  State s = cell_state(Mat3::Identity() * 1.0);
  s.stress.head<3>() = Vec3(0.8e5, 1.3e5, 0.0);  // x below target (compress), y above (extend)
  s.stiffness.head<3>() = Vec3(K, K, K);
  double integral_x = 0.0, integral_y = 0.0, hx = 1.0, hy = 1.0;
  for (int k = 0; k < 3; ++k) {
    advance_cell(model, loading, s);
    const double ex = target - 0.8e5, ey = target - 1.3e5;
    const double dex = (0.05 * ex + 0.002 * (integral_x + ex)) / K;
    const double dey = (0.05 * ey + 0.002 * (integral_y + ey)) / K;
    integral_x += ex;
    integral_y += ey;
    hx *= 1.0 - dex;
    hy *= 1.0 - dey;
    EXPECT_NEAR(s.cell.h(0, 0), hx, 1e-15);
    EXPECT_NEAR(s.cell.h(1, 1), hy, 1e-15);
    EXPECT_NEAR(s.control.servo_integral[0], integral_x, 1e-9);
    EXPECT_NEAR(s.control.servo_integral[1], integral_y, 1e-9);
  }
  EXPECT_LT(s.cell.h(0, 0), 1.0);  // too little stress: compress
  EXPECT_GT(s.cell.h(1, 1), 1.0);  // too much: extend
}

// A stress ramp's servo step by hand: the same law, towards the target of the step's end, from + rate (n + 1) dt
// after n steps of the leg; its target moves by rate dt per step, whatever the stresses.
TEST(Control, StressRampServoAimsAtTheTargetOfTheStepsEnd) {
  Deck deck = model_deck(1e4, 1e4, 1e-3);
  deck.servo = ServoDef{0.05, 0.002, 1e-3};
  const Model model = make_model(deck, {});
  const double from = 1.0e5, rate = 3.0e7, K = 2.0e8, s_x = 0.9e5;
  const AxisControl ramp{AxisMode::StressRamp, from, rate};
  const Loading loading{{ramp, AxisControl{AxisMode::Stress, from}, AxisControl{AxisMode::StrainIncrement, 0.0}}, 0.0};
  State s = cell_state(Mat3::Identity() * 1.0);
  s.stress.head<3>() = Vec3(s_x, from, 0.0);
  s.stiffness.head<3>() = Vec3(K, K, K);
  double integral = 0.0, hx = 1.0;
  for (int n = 0; n < 4; ++n) {
    const double target = from + rate * (n + 1) * model.dt;
    const Vec3 t = stress_targets(loading.axes, s.stress.head<3>(), (n + 1) * model.dt);
    EXPECT_DOUBLE_EQ(t[0], target);
    EXPECT_DOUBLE_EQ(t[1], from);  // a constant stress stays
    EXPECT_TRUE(std::isnan(t[2]));
    advance_cell(model, loading, s);
    const double err = target - s_x;
    const double de = (0.05 * err + 0.002 * (integral + err)) / K;
    integral += err;
    hx *= 1.0 - de;
    EXPECT_NEAR(s.cell.h(0, 0), hx, 1e-15) << n;
    EXPECT_NEAR(s.control.servo_integral[0], integral, 1e-6) << n;
    EXPECT_EQ(s.cell.h(1, 1), 1.0);  // at its target
  }
  // A falling ramp: the target is below the start by |rate| t.
  const AxisControl down{AxisMode::StressRamp, from, -rate};
  EXPECT_DOUBLE_EQ(down.stress_target(2e-3), from - rate * 2e-3);
}

TEST(Control, ServoSaturatesWithoutWindupAndWithoutContacts) {
  Deck deck = model_deck(1e4, 1e4, 1e-3);
  deck.servo = ServoDef{0.05, 0.002, 1e-6};
  const Model model = make_model(deck, {});
  const Loading loading{{AxisControl{AxisMode::Stress, 1e5}, AxisControl{AxisMode::Stress, 1e5},
                         AxisControl{AxisMode::Stress, 1e5}},
                        0.0};
  State s = cell_state(Mat3::Identity());
  // No contacts (K = 0): the largest increment, towards the target.
  s.stress.head<3>() = Vec3(0.0, 2e5, 0.0);
  s.stiffness.head<3>() = Vec3(0.0, 0.0, 1e3);  // z: a huge step asked for, capped
  advance_cell(model, loading, s);
  EXPECT_DOUBLE_EQ(s.cell.h(0, 0), 1.0 - 1e-6);
  EXPECT_DOUBLE_EQ(s.cell.h(1, 1), 1.0 + 1e-6);
  EXPECT_DOUBLE_EQ(s.cell.h(2, 2), 1.0 - 1e-6);
  EXPECT_EQ(s.control.servo_integral, Vec6::Zero());  // saturated: nothing accumulated
  EXPECT_TRUE(s.servo_saturated[0] && s.servo_saturated[1] && s.servo_saturated[2]);
  // A leg's own cap (core/plan servo_cap) replaces the model's.
  Loading leg_cap = loading;
  leg_cap.servo_cap = 4e-6;
  State t = cell_state(Mat3::Identity());
  t.stress.head<3>() = Vec3(0.0, 2e5, 0.0);
  t.stiffness.head<3>() = Vec3(0.0, 0.0, 1e3);
  advance_cell(model, leg_cap, t);
  EXPECT_DOUBLE_EQ(t.cell.h(0, 0), 1.0 - 4e-6);
  EXPECT_DOUBLE_EQ(t.cell.h(1, 1), 1.0 + 4e-6);
  // Within the cap: not saturated.
  t.stress.head<3>() = Vec3(1e5 - 1.0, 1e5, 1e5);
  t.stiffness.head<3>() = Vec3(1e9, 1e9, 1e9);
  advance_cell(model, leg_cap, t);
  EXPECT_FALSE(t.servo_saturated[0] || t.servo_saturated[1] || t.servo_saturated[2]);
}

// Shear axes (control.hpp's convention): a strain-driven shear axis sets its tilt from its exact engineering
// shear strain, g_ij = -(h_ij - h_ij(start)) / L_j; a shear axis the leg does not name keeps its tilt to the bit.
TEST(Control, ShearStrainFollowsItsIncrementsExactlyAndUnnamedTiltsAreHeld) {
  const double dt = 1e-3;
  const Model model = make_model(model_deck(1e4, 1e4, dt), {});
  const Mat3 h0 = (Mat3() << 2.0, 0.3, -0.1, 0.0, 3.0, 0.2, 0.0, 0.0, 4.0).finished();
  State s = cell_state(h0);
  begin_stage(s);
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  Loading loading{{AxisControl{AxisMode::StrainIncrement, 1e-4}, held, held}, 0.0};
  set_shear(loading.axes, {AxisControl{AxisMode::StrainIncrement, 2e-4}, AxisControl{AxisMode::StrainRate, -0.5}, std::nullopt});
  const int steps = 1000;
  advance_checking_velocity_gradient(model, loading, s, steps);
  EXPECT_DOUBLE_EQ(s.cell.h(0, 1), 0.3 - 3.0 * (steps * 2e-4));        // g12 = 0.2 over L2 = 3
  EXPECT_DOUBLE_EQ(s.cell.h(0, 2), -0.1 - 4.0 * (steps * -0.5 * dt));  // g13 = -0.5 over L3 = 4
  EXPECT_EQ(s.cell.h(1, 2), 0.2);                                      // x23 not named
  EXPECT_EQ(s.cell.h(1, 0), 0.0);
  EXPECT_EQ(s.cell.h(2, 0), 0.0);
  EXPECT_EQ(s.cell.h(2, 1), 0.0);
  const Vec3 g = shear_strains(s);
  EXPECT_NEAR(g[0], 0.2, 1e-14);
  EXPECT_NEAR(g[1], -0.5, 1e-14);
  EXPECT_EQ(g[2], 0.0);
  EXPECT_NEAR(axis_strains(s)[0], 0.1, 1e-14);  // the normal axes as before
  // A later leg continues from the present shear strains; x13, no longer named, stays where it is.
  begin_leg(s, 1);
  EXPECT_NEAR(s.control.leg_start_strains[3 + 0], 0.2, 1e-14);
  Loading back = loading;
  set_shear(back.axes, {AxisControl{AxisMode::StrainIncrement, -1e-4}, std::nullopt, std::nullopt});
  const double tilt13 = s.cell.h(0, 2);
  for (int k = 0; k < 500; ++k) advance_cell(model, back, s);
  EXPECT_NEAR(shear_strains(s)[0], 0.2 - 0.05, 1e-14);
  EXPECT_EQ(s.cell.h(0, 2), tilt13);
  // The same leg restarted where it stands (a rate check's branch, at half the rate): its normal and shear axes go
  // on from their present strains by the new increments, the servo's memory kept.
  s.control.servo_integral << 1.0, 2.0, 3.0, 4.0, 5.0, 6.0;
  restart_leg(s);
  EXPECT_EQ(s.control.leg_steps, 0);
  Loading half = back;
  half.axes[0].value = 0.5e-4;
  half.axes[3 + 0].value = -0.5e-4;
  for (int k = 0; k < 200; ++k) advance_cell(model, half, s);
  EXPECT_NEAR(shear_strains(s)[0], 0.15 - 0.01, 1e-14);
  EXPECT_NEAR(axis_strains(s)[0], 0.1 + 0.05 + 0.01, 1e-14);
  EXPECT_EQ(s.control.servo_integral, (Vec6() << 1.0, 2.0, 3.0, 4.0, 5.0, 6.0).finished());
}

// One shear servo step by hand: err = target - s_ij, dg = (gain err + integral_gain (I + err)) / K_ij,
// h_ij -= L_j dg. A negative target, and a zero target met exactly (the tilt stays).
TEST(Control, ShearServoStepFollowsItsLaw) {
  Deck deck = model_deck(1e4, 1e4, 1e-3);
  deck.servo = ServoDef{0.05, 0.002, 1e-3};
  const Model model = make_model(deck, {});
  const double target = -2.0e4, K = 5.0e7, s12 = 1.0e4, L2 = 1.5;
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  Loading loading{{held, held, held}, 0.0};
  set_shear(loading.axes, {AxisControl{AxisMode::Stress, target}, AxisControl{AxisMode::Stress, 0.0}, std::nullopt});
  State s = cell_state(Vec3(1.0, L2, 2.0).asDiagonal());
  begin_stage(s);
  s.stress.tail<3>() = Vec3(s12, 0.0, 3.0e3);
  s.stiffness.tail<3>() = Vec3(K, K, K);
  double integral = 0.0, tilt = 0.0;
  for (int k = 0; k < 3; ++k) {
    advance_cell(model, loading, s);
    const double err = target - s12;
    const double dg = (0.05 * err + 0.002 * (integral + err)) / K;
    integral += err;
    tilt -= L2 * dg;
    EXPECT_NEAR(s.cell.h(0, 1), tilt, 1e-15);
    EXPECT_NEAR(s.control.servo_integral[3 + 0], integral, 1e-9);
  }
  EXPECT_LT(shear_strains(s)[0], 0.0);  // too much shear stress: shear back
  EXPECT_EQ(s.cell.h(0, 2), 0.0);       // x13 at its zero target
  EXPECT_EQ(s.cell.h(1, 2), 0.0);       // x23 not named: its stress does not matter
  EXPECT_EQ(s.cell.h.diagonal(), Vec3(1.0, L2, 2.0));
  EXPECT_FALSE(s.servo_saturated[3 + 0]);
  // Nothing touching (K = 0): the cap, towards the target, and no integral.
  State t = cell_state(Mat3::Identity());
  begin_stage(t);
  t.stress.tail<3>() = Vec3(s12, 0.0, 0.0);
  advance_cell(model, loading, t);
  EXPECT_DOUBLE_EQ(t.cell.h(0, 1), 1e-3);  // dg = -cap: the tilt grows by L2 cap
  EXPECT_TRUE(t.servo_saturated[3 + 0]);
  EXPECT_EQ(t.control.servo_integral[3 + 0], 0.0);
}

// ---- shear on an FCC lattice: an elastic network with an analytic shear modulus ----
// Equal spheres on an FCC lattice (constant a = 1, overlap 1e-3 of the contact distance, frictionless): the
// lattice is centrosymmetric, so it deforms affinely and its contact network's shear modulus from the normal
// springs is C44 = kn / a (contact/test_contact_forces.cpp, FccShearStressAndShearStiffnessMatchAnalytic).
// Through the whole step loop: simple shear by strain (all other strains zero) gives s12 = C44 g12, and the
// shear servo finds the strain g12 = target / C44 that carries a target shear stress.
struct FccLattice {
  static constexpr double kKn = 1.0e4, kA = 1.0;
  double radius = 0.5 * (kA / std::sqrt(2.0)) * (1.0 + 1e-3);
  State state = testing::fcc_state(2, radius, kA, 0.05);
  Model model = make_model(model_deck(kKn, 0.0, 1e-4, testing::kUnitMassDensity, 0.1, 0.1),
                           std::vector<double>(state.particles.size(), radius));
  FccLattice() {
    begin_stage(state);
    rebuild_pairs(model, state);
    compute_contact_forces(model, 0.0, state, false);
  }
};

TEST(Control, SimpleShearOfAnFccLatticeFollowsItsShearModulus) {
  FccLattice lattice;
  State& s = lattice.state;
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  Loading loading{{held, held, held}, 0.0};
  set_shear(loading.axes, {AxisControl{AxisMode::StrainIncrement, 1e-8}, held, held});
  const int steps = 1000;
  for (int k = 0; k < steps; ++k) testing::advance_one_step(lattice.model, loading, s, k == 0);
  const double g = shear_strains(s)[0], modulus = FccLattice::kKn / FccLattice::kA;
  EXPECT_NEAR(g, steps * 1e-8, 1e-15);
  const Mat3 stress = testing::contact_stress(s);
  EXPECT_NEAR(stress(0, 1), modulus * g, 5e-3 * modulus * g);  // O(overlap/d + g) from the prestress
  // A strain-driven shear needs no shear sums in the pair loop; a stage's first evaluation makes them.
  EXPECT_FALSE(needs_shear_sums(loading));
  EXPECT_EQ(s.stress[3 + 0], 0.0);
  compute_contact_forces(lattice.model, 0.0, s, /*advance_slip=*/false);
  EXPECT_NEAR(s.stress[3 + 0], stress(0, 1), 1e-9 * stress(0, 0));
  EXPECT_NEAR(stress(0, 2), 0.0, 1e-6 * modulus * g);
  EXPECT_NEAR(stress(1, 2), 0.0, 1e-6 * modulus * g);
}

TEST(Control, ShearServoHoldsATargetOnAnFccLattice) {
  FccLattice lattice;
  State& s = lattice.state;
  const double modulus = FccLattice::kKn / FccLattice::kA, target = 0.1;  // [Pa]: g12 = 1e-5
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  Loading loading{{held, held, held}, 0.0};
  set_shear(loading.axes, {AxisControl{AxisMode::Stress, target}, AxisControl{AxisMode::Stress, 0.0}, std::nullopt});
  for (int k = 0; k < 3000; ++k) testing::advance_one_step(lattice.model, loading, s, k == 0);
  EXPECT_NEAR(s.stress[3 + 0], target, 1e-3 * target);
  EXPECT_NEAR(shear_strains(s)[0], target / modulus, 5e-3 * target / modulus);
  EXPECT_NEAR(s.stress[3 + 1], 0.0, 1e-6 * target);
  EXPECT_NEAR(shear_strains(s)[1], 0.0, 1e-9);
}

// ---- the servo on a real packing ----

// Prepares a ~250-sphere packing at 100 kPa (frictionless, loose equilibrium tolerances) with the runner.
class ServoOnPacking : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir();
    deck_ = new Deck(parse_deck(testing::small_deck_json(250, "[]"), (dir_->path() / "deck.json").string()));
    RunOptions options;
    options.out_dir = (dir_->path() / "run").string();
    options.threads = 1;
    options.quiet = true;
    run_deck(*deck_, options);
  }
  static void TearDownTestSuite() {
    delete deck_;
    delete dir_;
  }
  static testing::TempDir* dir_;
  static Deck* deck_;
};
testing::TempDir* ServoOnPacking::dir_ = nullptr;
Deck* ServoOnPacking::deck_ = nullptr;

// Triaxial compression under mixed control: x1 compressed at a fixed strain increment (1e-6 per step, 5x
// the paper's rate), x2 and x3 held at 100 kPa by the servo, friction 0.5. After a short transient every
// step's s22 and s33 stay within 0.5 % of the target (the worst seen is about 0.25 %; the servo acts on the
// previous step's stress, so the deviation grows with the loading rate), while s11 grows well above it.
TEST_F(ServoOnPacking, HoldsTargetStressWhileAnotherAxisIsCompressed) {
  State s = read_state((dir_->path() / "run" / "prepared.state").string());
  s.control = ControlState{};
  s.control.reference.head<3>() = s.cell.h.diagonal();
  s.control.reference_volume = s.cell.volume();
  const Model model = make_model(*deck_, s.particles.radius);
  const double target = 1.0e5, increment = 1e-6;
  const Loading loading{{AxisControl{AxisMode::StrainIncrement, increment}, AxisControl{AxisMode::Stress, target},
                         AxisControl{AxisMode::Stress, target}},
                        0.5};
  rebuild_pairs(model, s);
  compute_contact_forces(model, loading.friction, s, false);
  const double s11_start = s.stress[0];
  EXPECT_NEAR(s11_start, target, 0.03 * target);  // the preparation did reach the target

  const int steps = 4000, transient = 300;
  double worst = 0.0, mean_error = 0.0;
  for (int k = 0; k < steps; ++k) {
    testing::advance_one_step(model, loading, s, k == 0);
    if (k < transient) continue;
    for (int a : {1, 2}) {
      const double err = (s.stress[a] - target) / target;
      worst = std::max(worst, std::abs(err));
      mean_error += err / (2.0 * (steps - transient));
    }
  }
  RecordProperty("worst_relative_error", std::to_string(worst));
  RecordProperty("mean_relative_error", std::to_string(mean_error));
  EXPECT_LT(worst, 0.005);
  EXPECT_LT(std::abs(mean_error), 0.001);  // no steady lag: the integral term removes it
  EXPECT_NEAR(axis_strains(s)[0], steps * increment, 1e-12);
  EXPECT_GT(s.stress[0], 1.5 * target);
  // The servo moved the lateral walls (the sample changed volume), not just held them.
  EXPECT_GT(std::abs(axis_strains(s)[1]), 1e-5);
}

// Simple shear of the packing (g12 driven, s22 held at 100 kPa, e1 = e3 = 0) with s13 and s23 servo-held at
// zero: the servos hold their targets, and the leg continued from a state file (format 5, the shear record)
// gives the same bytes as the uninterrupted one.
TEST_F(ServoOnPacking, SimpleShearHoldsItsStressesAndResumesBitForBit) {
  State s = read_state((dir_->path() / "run" / "prepared.state").string());
  begin_stage(s);
  const Model model = make_model(*deck_, s.particles.radius);
  const double target = 1.0e5, increment = 1e-6;
  const AxisControl held{AxisMode::StrainIncrement, 0.0};
  Loading loading{{held, AxisControl{AxisMode::Stress, target}, held}, 0.5};
  set_shear(loading.axes, {AxisControl{AxisMode::StrainIncrement, increment}, AxisControl{AxisMode::Stress, 0.0},
                   AxisControl{AxisMode::Stress, 0.0}});
  rebuild_pairs(model, s);
  compute_contact_forces(model, loading.friction, s, false);
  const int steps = 2000, transient = 300, cut = 1200;
  double worst_normal = 0.0, worst_shear = 0.0;
  std::string resumed_from;
  for (int k = 0; k < cut; ++k) {
    testing::advance_one_step(model, loading, s, k == 0);
    if (k < transient) continue;
    const double p = s.stress.head<3>().sum() / 3.0;
    worst_normal = std::max(worst_normal, std::abs(s.stress[1] / target - 1.0));
    worst_shear = std::max({worst_shear, std::abs(s.stress[3 + 1]) / p, std::abs(s.stress[3 + 2]) / p});
  }
  State resumed = parse_state(serialize_state(s, "checkpoint", R"({"contact.kn":1})"));
  for (int k = cut; k < steps; ++k) testing::advance_one_step(model, loading, s);
  for (int k = cut; k < steps; ++k) testing::advance_one_step(model, loading, resumed, k == cut);
  EXPECT_EQ(serialize_state(resumed, "end"), serialize_state(s, "end"));
  EXPECT_NEAR(shear_strains(s)[0], steps * increment, 1e-15);
  EXPECT_GT(s.stress[3 + 0], 0.02 * target);  // the packing carries the shear it is given
  EXPECT_LT(worst_normal, 0.005);
  EXPECT_LT(worst_shear, 0.005);  // relative to p, as the control check measures a zero target
  EXPECT_EQ(axis_strains(s)[0], 0.0);
  EXPECT_EQ(axis_strains(s)[2], 0.0);
  RecordProperty("worst_s22_error", std::to_string(worst_normal));
  RecordProperty("worst_zero_shear_error", std::to_string(worst_shear));
}

// A principal-axis rotation: sigma1 = 120 kPa and sigma3 = 100 kPa turned through 90 degrees in the x1-x2 plane
// (x3 held at 100 kPa), its three servos aiming at the targets of each step's end. The principal values of the
// plane's stress stay within 0.5 % of theirs after the start-up transient, and the major principal direction
// follows the angle.
TEST_F(ServoOnPacking, PrincipalAxesRotateAtFixedPrincipalValues) {
  State s = read_state((dir_->path() / "run" / "prepared.state").string());
  begin_stage(s);
  const Model model = make_model(*deck_, s.particles.radius);
  const double sigma1 = 1.2e5, sigma3 = 1.0e5;
  const int steps = 12000, transient = 2000;
  PrincipalRotation rotation{0, sigma1, sigma3, 0.0, (M_PI / 2.0) / steps, true};
  const std::array<double, 3> t0 = rotation.targets(0.0, model.dt);
  Loading loading{{AxisControl{AxisMode::Stress, t0[0]}, AxisControl{AxisMode::Stress, t0[1]},
                   AxisControl{AxisMode::Stress, 1.0e5}},
                  0.5};
  set_shear(loading.axes, {AxisControl{AxisMode::Stress, t0[2]}, std::nullopt, std::nullopt});
  loading.rotation = rotation;
  rebuild_pairs(model, s);
  compute_contact_forces(model, loading.friction, s, false);
  double worst_value = 0.0, worst_angle = 0.0;
  for (int k = 0; k < steps; ++k) {
    testing::advance_one_step(model, loading, s, k == 0);
    if (k < transient) continue;
    const double s11 = s.stress[0], s22 = s.stress[1], s12 = s.stress[3 + 0];
    const double m = 0.5 * (s11 + s22), r = std::hypot(0.5 * (s11 - s22), s12);
    worst_value = std::max({worst_value, std::abs((m + r) / sigma1 - 1.0), std::abs((m - r) / sigma3 - 1.0)});
    const double angle = 0.5 * std::atan2(2.0 * s12, s11 - s22);  // of the major principal stress from x1
    const double off = angle - rotation.angle((k + 1) * model.dt, model.dt);
    worst_angle = std::max(worst_angle, std::abs(off - M_PI * std::round(off / M_PI)));  // (directions mod 180)
  }
  RecordProperty("worst_principal_value_error", std::to_string(worst_value));
  RecordProperty("worst_angle_error_deg", std::to_string(worst_angle * 180.0 / M_PI));
  EXPECT_LT(worst_value, 0.005);
  EXPECT_LT(worst_angle * 180.0 / M_PI, 2.0);
  EXPECT_NEAR(s.stress[1], sigma1, 0.005 * sigma1);  // at 90 degrees sigma1 is on x2
  EXPECT_NEAR(s.stress[0], sigma3, 0.005 * sigma1);
  EXPECT_NEAR(s.stress[2], 1.0e5, 0.005 * 1.0e5);
}

}  // namespace
}  // namespace celldem
