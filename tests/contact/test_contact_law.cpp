// The composed contact law (solver/contact/contact_law.hpp) against analytic answers: Hertz's force-overlap
// law and tangent stiffness, a Hertzian collision's duration and restitution, Mindlin's tangential stiffness
// and its Coulomb cap, the rolling resistance moment and its cap, Marshall's twisting moment and its cap, the
// work each tangential law returns over a closed load-unload cycle; then the pair loop's rotational springs and
// mindlin_rescale's contact radii across rebuilds, state files and thread counts.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <cstring>
#include <random>
#include <type_traits>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "integrate/leapfrog.hpp"
#include "io/state_file.hpp"
#include "neighbor/neighbor_list.hpp"
#include "step.hpp"

namespace celldem::contact_law_test {  // (named: the files of test_contact compile as one unit)
namespace {

constexpr double kRi = 0.5, kRj = 0.3, kE = 1.0e7, kNu = 0.3;
constexpr double kReff = kRi * kRj / (kRi + kRj);

using HertzMindlin = Law<NormalModel::Hertz, TangentialModel::Mindlin, RollingModel::None, TwistingModel::None>;
using LinearRolling = Law<NormalModel::Linear, TangentialModel::LinearHistory, RollingModel::Sds, TwistingModel::None>;
using LinearTwisting =
    Law<NormalModel::Linear, TangentialModel::LinearHistory, RollingModel::None, TwistingModel::Marshall>;
using Everything = Law<NormalModel::Hertz, TangentialModel::Mindlin, RollingModel::Sds, TwistingModel::Marshall>;
using HertzMindlinRescale =
    Law<NormalModel::Hertz, TangentialModel::MindlinRescale, RollingModel::None, TwistingModel::None>;

// E* and G* written out independently of ContactDef's helpers.
double e_star() { return 1.0 / (2.0 * (1.0 - kNu * kNu) / kE); }
double g_star() {
  const double g = kE / (2.0 * (1.0 + kNu));
  return 1.0 / (2.0 * (2.0 - kNu) / g);
}

ContactParams params(double mu = 0.5) {
  ContactDef c;
  c.kn = 2.0e4;
  c.kt = 1.0e4;
  c.youngs_modulus = kE;
  c.poisson_ratio = kNu;
  c.rolling_stiffness = 3.0e3;
  c.rolling_damping = 0.0;
  return contact_params(c, Friction(mu, 0.2));
}

Vec3 branch_z(double overlap) { return Vec3(0.0, 0.0, kRi + kRj - overlap); }

template <class L>
ContactResult touch(const ContactParams& p, double overlap, const Vec3& dv = Vec3::Zero(), const Vec3& wi = Vec3::Zero(),
                    const Vec3& wj = Vec3::Zero(), const ContactHistory& h = {}, double dt = 1e-4) {
  return evaluate_contact<L>(p, branch_z(overlap), kRi, kRj, dv, wi, wj, h, dt);
}

ContactHistory history_of(const ContactResult& r) {
  return {real3(r.tangential), real3(r.rolling), r.twist, r.contact_radius};
}

TEST(ContactLaw, WithLawPicksTheNamedSubModels) {
  ContactDef c;
  EXPECT_TRUE(with_law(c, [](auto law) { return std::is_same_v<decltype(law), LinearLaw>; }));
  c.normal = NormalModel::Hertz;
  c.tangential = TangentialModel::Mindlin;
  c.rolling = RollingModel::Sds;
  c.twisting = TwistingModel::Marshall;
  EXPECT_TRUE(with_law(c, [](auto law) { return std::is_same_v<decltype(law), Everything>; }));
  c.normal = NormalModel::Linear;
  c.tangential = TangentialModel::LinearHistory;
  c.twisting = TwistingModel::None;
  EXPECT_TRUE(with_law(c, [](auto law) { return std::is_same_v<decltype(law), LinearRolling>; }));
}

// F = 4/3 E* sqrt(R*) d^3/2, and the reported stiffness is dF/dd (central difference).
TEST(Hertz, ForceOverlapLawAndTangentStiffness) {
  for (double d : {1e-5, 1e-4, 1e-3, 1e-2}) {
    const ContactResult r = touch<HertzMindlin>(params(), d);
    ASSERT_TRUE(r.touching);
    const double expected = 4.0 / 3.0 * e_star() * std::sqrt(kReff) * std::pow(d, 1.5);
    EXPECT_NEAR(r.normal_force, expected, 1e-9 * expected) << d;  // the overlap from |branch| keeps ~11 digits
    EXPECT_NEAR(r.force.z(), expected, 1e-9 * expected) << d;
    const double h = 1e-4 * d;
    const double slope = (touch<HertzMindlin>(params(), d + h).normal_force -
                          touch<HertzMindlin>(params(), d - h).normal_force) / (2.0 * h);
    EXPECT_NEAR(r.normal_stiffness, slope, 1e-6 * slope) << d;
  }
  EXPECT_FALSE(touch<HertzMindlin>(params(), -1e-6).touching);
}

// Two spheres meet head on without damping or friction, through the whole step pipeline: Hertz's contact
// time t_c = 2.94 d_max / v (d_max = (15 m* v^2 / (16 E* sqrt(R*)))^2/5) and an elastic rebound.
TEST(Hertz, CollisionDurationAndRestitutionMatchHertzTheory) {
  Deck deck = testing::model_deck(1.0, 1.0, 1.0);
  deck.contact.normal = NormalModel::Hertz;
  deck.contact.tangential = TangentialModel::Mindlin;
  deck.contact.youngs_modulus = kE;
  deck.contact.poisson_ratio = kNu;
  deck.sample.diameters = {2.0 * kRi, 2.0 * kRj};
  const Model probe = make_model(deck, {kRi, kRj});
  const double m_eff = probe.mass_of(kRi) * probe.mass_of(kRj) / (probe.mass_of(kRi) + probe.mass_of(kRj));
  const double v = 0.1;
  const double d_max = std::pow(15.0 * m_eff * v * v / (16.0 * e_star() * std::sqrt(kReff)), 0.4);
  const double t_contact = 2.943275 * d_max / v;  // 2 Gamma(7/5) Gamma(1/2) / Gamma(9/10)
  deck.time_step = t_contact / 2000.0;
  const Model model = make_model(deck, {kRi, kRj});
  State s = testing::make_state(Mat3::Identity() * 10.0, {kRi, kRj}, {Vec3(5, 5, 5), Vec3(5, 5, 5.0 + kRi + kRj + 1e-12)},
                                0.05);
  s.particles.velocity[0] = Vec3(0, 0, v * probe.mass_of(kRj) / (probe.mass_of(kRi) + probe.mass_of(kRj)));
  s.particles.velocity[1] = Vec3(0, 0, -v * probe.mass_of(kRi) / (probe.mass_of(kRi) + probe.mass_of(kRj)));
  evaluate_forces(model, Friction(0.5), s);
  int touching_steps = 0;
  for (int k = 0; k < 20000 && (touching_steps == 0 || s.touching > 0); ++k) {
    testing::advance_one_step(model, testing::fixed_cell(0.5), s);
    touching_steps += s.touching > 0 ? 1 : 0;
  }
  EXPECT_NEAR(touching_steps * deck.time_step, t_contact, 2e-3 * t_contact);
  const double rebound = s.particles.velocity[1].z() - s.particles.velocity[0].z();
  EXPECT_NEAR(rebound, v, 1e-4 * v);  // elastic: the relative velocity reverses
}

// Without slip the tangential force is -8 G* a xi, a = sqrt(R* d): four times the overlap, twice the stiffness.
TEST(Mindlin, TangentialStiffnessIsEightGStarA) {
  const double dt = 1e-4, slip = 1e-6;
  for (double d : {1e-4, 4e-4}) {
    const ContactResult r = touch<HertzMindlin>(params(100.0), d, Vec3(slip / dt, 0, 0), Vec3::Zero(), Vec3::Zero(),
                                                {}, dt);
    ASSERT_FALSE(r.sliding);
    const double a = std::sqrt(kReff * d);
    EXPECT_NEAR(r.force.x(), -8.0 * g_star() * a * slip, 1e-9 * 8.0 * g_star() * a * slip) << d;
    EXPECT_NEAR(r.tangential.x(), slip, 1e-15);
  }
}

// The slider caps |ft| at mu fn and rescales the spring with it, so the next step starts from the cap.
TEST(Mindlin, CoulombCapRescalesTheSpring) {
  const double d = 1e-3, dt = 1e-4, mu = 0.3;
  const ContactResult r = touch<HertzMindlin>(params(mu), d, Vec3(0, 10.0, 0), Vec3::Zero(), Vec3::Zero(), {}, dt);
  ASSERT_TRUE(r.sliding);
  EXPECT_NEAR(std::abs(r.force.y()), mu * r.normal_force, 1e-12 * r.normal_force);
  const double kt = 8.0 * g_star() * std::sqrt(kReff * d);
  EXPECT_NEAR(-kt * r.tangential.y(), r.force.y(), 1e-12 * r.normal_force);
}

// ---- a closed cycle of normal overlap and tangential displacement, without sliding ----
//
// Sphere i stays at the origin; j sits at (u, 0, ri + rj - d) as far as the work goes: the branch stays on z
// (the normal does not turn) and the tangential displacement u enters the law as the slip dv = du/dt. The
// cycle is a rectangle in (d, u) run in one of two orders, each leg in equal steps:
//   stretch first:  u 0 -> U at d0,  d d0 -> d1 at u = U,  u U -> 0 at d1,  d d1 -> d0 at u = 0
//   load first:     d d0 -> d1 at u = 0,  u 0 -> U at d1,  d d1 -> d0 at u = U,  u U -> 0 at d0
// The work the contact force does on j, summed by the trapezoid rule over the steps, is what the cycle returns
// (> 0: energy created). The normal force depends on d only and is sampled at the same d going and coming
// back, so its work cancels to round-off; the tangential force is linear in u within a leg of constant d, so
// the trapezoid rule is exact there. With k = kt (linear_history) or 8 G* a (mindlin, a = sqrt(R* d)),
// k0 and k1 at d0 and d1, r = a0 / a1 = k0 / k1:
//   linear_history   0 in both orders (one stiffness: a potential 1/2 kt u^2).
//   mindlin          stretch first: the spring stretched at k0 takes 1/2 k0 U^2, stiffens to k1 at constant u
//                    (no work) and gives back 1/2 k1 U^2: +1/2 (k1 - k0) U^2 created. Load first: -1/2 (k1 -
//                    k0) U^2 (absorbed). The stored displacement is u throughout, so nothing is left at the end.
//   mindlin_rescale  stretch first: as mindlin, +1/2 (k1 - k0) U^2: the spring is rescaled only when a shrinks,
//                    and here the contact unloads at u = 0 (LAMMPS's mindlin_rescale does the same). Load first:
//                    stretched at k1 (takes 1/2 k1 U^2), unloaded at constant u the spring shrinks to s0 = r U
//                    (the step factors a_k / a_k-1 multiply to r), and going back by U at k0 it gives
//                    1/2 k0 (s0^2 - (s0 - U)^2): in all 1/2 k1 U^2 (2 r^2 - r - 1) = 1/2 k1 U^2 (2r + 1)(r - 1) < 0,
//                    and a spring s0 - U = -(1 - r) U is left (1/2 k0 (1 - r)^2 U^2 stored).
struct CycleResult {
  double work = 0.0;    // [J] done on j by the contact over the cycle
  double spring = 0.0;  // [m] the stored tangential displacement (x) at the end
  bool slid = false;
};

template <class L>
CycleResult closed_cycle(const ContactParams& p, double d0, double d1, double stretch, bool stretch_first) {
  constexpr int kSteps = 1000;
  const double dt = 1e-4;
  CycleResult out;
  double d = d0, u = 0.0;
  ContactResult c = touch<L>(p, d);  // the contact starts at rest at d0
  ContactHistory h = history_of(c);
  const auto go = [&](double d_end, double u_end) {  // one leg, from (d, u) to (d_end, u_end)
    const double d_start = d, u_start = u;
    for (int k = 1; k <= kSteps; ++k) {
      const double f = static_cast<double>(k) / kSteps;
      const double d_next = d_start + (d_end - d_start) * f, u_next = u_start + (u_end - u_start) * f;
      const ContactResult next = touch<L>(p, d_next, Vec3((u_next - u) / dt, 0.0, 0.0), Vec3::Zero(), Vec3::Zero(),
                                          h, dt);
      out.work += 0.5 * (c.force + next.force).dot(Vec3(u_next - u, 0.0, d - d_next));  // j moves by (du, 0, -dd)
      out.slid = out.slid || next.sliding;
      c = next;
      h = history_of(c);
      d = d_next;
      u = u_next;
    }
  };
  if (stretch_first) {
    go(d0, stretch);
    go(d1, stretch);
    go(d1, 0.0);
    go(d0, 0.0);
  } else {
    go(d1, 0.0);
    go(d1, stretch);
    go(d0, stretch);
    go(d0, 0.0);
  }
  out.spring = c.tangential.x();
  return out;
}

constexpr double kD0 = 1e-4, kD1 = 4e-4, kStretch = 1e-6;  // a1 = 2 a0, r = 1/2
constexpr double kCycleMu = 10.0;                            // |ft| / fn stays below 0.02: no sliding

double mindlin_stiffness(double d) { return 8.0 * g_star() * std::sqrt(kReff * d); }

// The round-off allowed on a cycle's work: 1e-9 of the spring energy 1/2 k1 U^2 (the normal force's work,
// about 1e6 times larger, cancels to a few 1e-16 of itself).
double cycle_tolerance(double k1) { return 1e-9 * 0.5 * k1 * kStretch * kStretch; }

TEST(EnergyCycle, LinearHistoryReturnsNothing) {
  const ContactParams p = params(kCycleMu);
  for (bool stretch_first : {true, false}) {
    const CycleResult r = closed_cycle<LinearLaw>(p, kD0, kD1, kStretch, stretch_first);
    ASSERT_FALSE(r.slid);
    EXPECT_NEAR(r.work, 0.0, cycle_tolerance(p.kt)) << stretch_first;
    EXPECT_NEAR(r.spring, 0.0, 1e-12 * kStretch);
  }
}

TEST(EnergyCycle, MindlinCreatesHalfDeltaKXiSquaredWhenStretchedBeforeLoading) {
  const ContactParams p = params(kCycleMu);
  const double k0 = mindlin_stiffness(kD0), k1 = mindlin_stiffness(kD1);
  const double created = 0.5 * (k1 - k0) * kStretch * kStretch;
  const CycleResult stretch_first = closed_cycle<HertzMindlin>(p, kD0, kD1, kStretch, true);
  const CycleResult load_first = closed_cycle<HertzMindlin>(p, kD0, kD1, kStretch, false);
  ASSERT_FALSE(stretch_first.slid || load_first.slid);
  EXPECT_NEAR(stretch_first.work, created, cycle_tolerance(k1));
  EXPECT_NEAR(load_first.work, -created, cycle_tolerance(k1));
  EXPECT_NEAR(stretch_first.spring, 0.0, 1e-12 * kStretch);
  EXPECT_NEAR(load_first.spring, 0.0, 1e-12 * kStretch);
}

TEST(EnergyCycle, MindlinRescaleShrinksTheSpringOnUnloadingOnly) {
  const ContactParams p = params(kCycleMu);
  const double k0 = mindlin_stiffness(kD0), k1 = mindlin_stiffness(kD1), r = std::sqrt(kD0 / kD1);
  const double u2 = kStretch * kStretch;
  const CycleResult stretch_first = closed_cycle<HertzMindlinRescale>(p, kD0, kD1, kStretch, true);
  const CycleResult load_first = closed_cycle<HertzMindlinRescale>(p, kD0, kD1, kStretch, false);
  ASSERT_FALSE(stretch_first.slid || load_first.slid);
  // Loading at a stretched spring is not rescaled: the same energy as mindlin is created.
  EXPECT_NEAR(stretch_first.work, 0.5 * (k1 - k0) * u2, cycle_tolerance(k1));
  EXPECT_NEAR(stretch_first.spring, 0.0, 1e-12 * kStretch);
  // Unloading at a stretched spring scales it by a / a_old: energy absorbed, a spring left.
  EXPECT_NEAR(load_first.work, 0.5 * k1 * u2 * (2.0 * r + 1.0) * (r - 1.0), cycle_tolerance(k1));
  EXPECT_NEAR(load_first.spring, -(1.0 - r) * kStretch, 1e-9 * kStretch);
}

// The factor itself: a / a_old when a shrank, 1 when it grew or stayed, and for a new contact (a_old = 0).
TEST(EnergyCycle, MindlinRescaleFactor) {
  EXPECT_EQ(mindlin_rescale_factor(1.0, 2.0), 0.5);
  EXPECT_EQ(mindlin_rescale_factor(2.0, 1.0), 1.0);
  EXPECT_EQ(mindlin_rescale_factor(1.0, 1.0), 1.0);
  EXPECT_EQ(mindlin_rescale_factor(1.0, 0.0), 1.0);
}

// Sphere i rolls on j about x (normal z): the rolling spring grows as k_roll R* w t, its moment R* |f_roll|
// opposes the relative rotation, equal and opposite on j, until it caps at mu_roll R* fn.
TEST(Rolling, MomentGrowsLinearlyThenCapsAtMuRollRStarFn) {
  const double d = 1e-3, dt = 1e-4, w = 2.0;
  const ContactParams p = params(0.0);  // no sliding friction: the only moments are rolling ones
  const double fn = p.kn * d, cap = p.mu_roll * kReff * fn;
  ContactHistory h;
  bool capped = false;
  for (int k = 1; k <= 400; ++k) {
    const ContactResult r = touch<LinearRolling>(p, d, Vec3::Zero(), Vec3(w, 0, 0), Vec3::Zero(), h, dt);
    h = history_of(r);
    const double elastic = p.k_roll * kReff * kReff * w * k * dt;
    const double expected = std::min(elastic, cap);
    capped = capped || elastic > cap;
    EXPECT_NEAR(r.torque_i.x(), -expected, 1e-9 * cap) << k;  // opposes w_i
    EXPECT_NEAR(r.torque_j.x(), expected, 1e-9 * cap) << k;
    EXPECT_NEAR(r.torque_i.y(), 0.0, 1e-12 * cap);
    EXPECT_NEAR((r.force - Vec3(0, 0, fn)).norm(), 0.0, 1e-9 * fn);  // the normal force alone
  }
  EXPECT_TRUE(capped);
  // After the cap the spring holds the capped force: turning back unloads from there at once.
  const ContactResult back = touch<LinearRolling>(p, d, Vec3::Zero(), Vec3(-w, 0, 0), Vec3::Zero(), h, dt);
  EXPECT_NEAR(back.torque_i.x(), -cap + p.k_roll * kReff * kReff * w * dt, 1e-9 * cap);
}

// Sphere i spins about the normal: Marshall's moment 0.5 kt a^2 theta opposes it, capped at 2/3 a mu fn.
TEST(Twisting, MomentIsHalfKtASquaredThetaThenCaps) {
  const double d = 1e-3, dt = 1e-4, w = 5.0, mu = 0.5;
  const ContactParams p = params(mu);
  const double a = std::sqrt(kReff * d), fn = p.kn * d;
  const double k_twist = 0.5 * p.kt * a * a, cap = 2.0 / 3.0 * a * mu * fn;
  ContactHistory h;
  bool capped = false;
  for (int k = 1; k <= 3000; ++k) {
    const ContactResult r = touch<LinearTwisting>(p, d, Vec3::Zero(), Vec3(0, 0, w), Vec3::Zero(), h, dt);
    h = history_of(r);
    const double elastic = k_twist * w * k * dt;
    capped = capped || elastic > cap;
    EXPECT_NEAR(r.torque_i.z(), -std::min(elastic, cap), 1e-9 * cap) << k;
    EXPECT_NEAR(r.torque_j.z(), std::min(elastic, cap), 1e-9 * cap) << k;
    EXPECT_NEAR((r.force - Vec3(0, 0, fn)).norm(), 0.0, 1e-9 * fn);  // spinning about the normal slides nothing
  }
  EXPECT_TRUE(capped);
}

TEST(ContactLaw, ApartForgetsEverySpring) {
  const ContactHistory h{{1e-4, 0, 0}, {0, 2e-4, 0}, 0.3};
  const ContactResult r = touch<Everything>(params(), -1e-6, Vec3::Zero(), Vec3(1, 2, 3), Vec3::Zero(), h);
  EXPECT_FALSE(r.touching);
  EXPECT_EQ(r.tangential, Vec3::Zero());
  EXPECT_EQ(r.rolling, Vec3::Zero());
  EXPECT_EQ(r.twist, 0.0);
  EXPECT_EQ(r.torque_i, Vec3::Zero());
}

// ---- the pair loop with rotational springs ----

Deck everything_deck() {
  Deck deck = testing::model_deck(0.0, 0.0, 1e-5);
  ContactDef& c = deck.contact;
  c.normal = NormalModel::Hertz;
  c.tangential = TangentialModel::Mindlin;
  c.rolling = RollingModel::Sds;
  c.twisting = TwistingModel::Marshall;
  c.youngs_modulus = kE;
  c.poisson_ratio = kNu;
  c.rolling_stiffness = 1.0e3;
  c.reference_overlap = 1e-3;
  return deck;
}

// The rolling and twisting springs are carried across a rebuild and through a state file (format 3), so that
// a resumed state computes the same forces; a law without them writes format 2 as before.
TEST(ContactForces, RotationalSpringsSurviveRebuildAndStateFile) {
  const Deck deck = everything_deck();
  const Model model = make_model(deck, std::vector<double>(27, 0.5));
  State s = testing::jostled_lattice(3, 5, 0.01, 0.01, 5.0);
  rebuild_pairs(model, s);
  for (int k = 0; k < 5; ++k) compute_contact_forces(model, Friction(0.5, 0.1), s);
  ASSERT_EQ(s.pairs.rolling.size(), s.pairs.size());
  double rolling = 0.0, twist = 0.0;
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    rolling += s.pairs.rolling[q].norm();
    twist += std::abs(s.pairs.twist[q]);
  }
  ASSERT_GT(rolling, 0.0);
  ASSERT_GT(twist, 0.0);

  State rebuilt = s;
  rebuild_pairs(model, rebuilt);
  State loaded = parse_state(serialize_state(s, "test"));
  rebuild_pairs(model, loaded);
  compute_contact_forces(model, Friction(0.5, 0.1), s);
  compute_contact_forces(model, Friction(0.5, 0.1), rebuilt);
  compute_contact_forces(model, Friction(0.5, 0.1), loaded);
  EXPECT_EQ(rebuilt.pairs.rolling, s.pairs.rolling);
  EXPECT_EQ(rebuilt.pairs.twist, s.pairs.twist);
  EXPECT_EQ(rebuilt.particles.torque, s.particles.torque);
  EXPECT_EQ(loaded.pairs.rolling, s.pairs.rolling);
  EXPECT_EQ(loaded.pairs.twist, s.pairs.twist);
  EXPECT_EQ(loaded.particles.torque, s.particles.torque);

  const std::string bytes = serialize_state(s, "test");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, sizeof version);
  EXPECT_EQ(version, 3u);
  const Model linear = make_model(testing::model_deck(1e4, 1e4, 1e-5), std::vector<double>(27, 0.5));
  State plain = testing::jostled_lattice(3, 5, 0.01, 0.01, 5.0);
  rebuild_pairs(linear, plain);
  compute_contact_forces(linear, 0.5, plain);
  std::memcpy(&version, serialize_state(plain, "test").data() + 8, sizeof version);
  EXPECT_EQ(version, 2u);
}

// mindlin_rescale keeps each pair's contact radius (only for that law), across a rebuild and through a state
// file (format 4), so that a resumed state rescales as the run would have.
TEST(ContactForces, MindlinRescaleRadiiSurviveRebuildAndStateFile) {
  Deck deck = everything_deck();
  deck.contact.tangential = TangentialModel::MindlinRescale;
  deck.contact.rolling = RollingModel::None;
  deck.contact.twisting = TwistingModel::None;
  const Model model = make_model(deck, std::vector<double>(27, 0.5));
  State s = testing::jostled_lattice(3, 5, 0.01, 0.01, 5.0);
  rebuild_pairs(model, s);
  EXPECT_TRUE(s.pairs.rolling.empty());
  ASSERT_EQ(s.pairs.contact_radius.size(), s.pairs.size());
  compute_contact_forces(model, 0.5, s);
  std::size_t touching = 0;
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    const bool touches = s.pairs.flags[q] & kTouching;
    touching += touches;
    EXPECT_EQ(s.pairs.contact_radius[q] > 0.0, touches) << q;
  }
  ASSERT_GT(touching, 0u);

  State rebuilt = s;
  rebuild_pairs(model, rebuilt);
  const std::string bytes = serialize_state(s, "test");
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, sizeof version);
  EXPECT_EQ(version, 7u);  // contact radii: format 4 on, with the six-component control record (7)
  State loaded = parse_state(bytes);
  rebuild_pairs(model, loaded);
  EXPECT_EQ(rebuilt.pairs.contact_radius, s.pairs.contact_radius);
  EXPECT_EQ(loaded.pairs.contact_radius, s.pairs.contact_radius);
  for (State* t : {&s, &rebuilt, &loaded}) {  // the cell expands: every contact unloads and is rescaled
    t->cell.h *= 1.0 + 1e-4;
    compute_contact_forces(model, 0.5, *t);
  }
  EXPECT_EQ(rebuilt.pairs.tangential, s.pairs.tangential);
  EXPECT_EQ(loaded.pairs.tangential, s.pairs.tangential);
  EXPECT_EQ(loaded.pairs.force, s.pairs.force);

  // Without the radii (a list built for mindlin) the law refuses to run rather than rescale from zero.
  Deck plain = deck;
  plain.contact.tangential = TangentialModel::Mindlin;
  State other = testing::jostled_lattice(3, 5, 0.01, 0.01, 5.0);
  rebuild_pairs(make_model(plain, std::vector<double>(27, 0.5)), other);
  EXPECT_TRUE(other.pairs.contact_radius.empty());
  EXPECT_THROW(compute_contact_forces(model, 0.5, other), std::logic_error);
}

// Every law's results are the same bits on 1, 2 and 3 threads.
TEST(ContactForces, RotationalLawIndependentOfThreadCount) {
  const Model model = make_model(everything_deck(), std::vector<double>(343, 0.5));
  const State base = testing::jostled_lattice(7, 11, 0.01, 0.01, 5.0);
  const std::vector<State> results = testing::on_thread_counts(model, base, Friction(0.4, 0.1), {1, 2, 3});
  ASSERT_GT(results[0].touching, 500);
  for (std::size_t r = 1; r < results.size(); ++r) {
    EXPECT_EQ(results[r].stress.head<3>(), results[0].stress.head<3>());
    EXPECT_EQ(results[r].pairs.rolling, results[0].pairs.rolling);
    EXPECT_EQ(results[r].pairs.twist, results[0].pairs.twist);
    EXPECT_EQ(results[r].particles.spin, results[0].particles.spin);
  }
}

TEST(ContactForces, MindlinRescaleIndependentOfThreadCount) {
  Deck deck = everything_deck();
  deck.contact.tangential = TangentialModel::MindlinRescale;
  const Model model = make_model(deck, std::vector<double>(343, 0.5));
  const State base = testing::jostled_lattice(7, 11, 0.01, 0.01, 5.0);
  const std::vector<State> results = testing::on_thread_counts(model, base, Friction(0.4, 0.1), {1, 2, 3});
  ASSERT_GT(results[0].touching, 500);
  for (std::size_t r = 1; r < results.size(); ++r) {
    EXPECT_EQ(results[r].stress.head<3>(), results[0].stress.head<3>());
    EXPECT_EQ(results[r].pairs.contact_radius, results[0].pairs.contact_radius);
    EXPECT_EQ(results[r].pairs.tangential, results[0].pairs.tangential);
    EXPECT_EQ(results[r].particles.spin, results[0].particles.spin);
  }
}

}  // namespace
}  // namespace celldem::contact_law_test
