// The stability limit per contact mode (core/plan.hpp, critical_time_steps) against two equal spheres in a
// sticking contact, integrated with the project's contact law (contact/contact_law.hpp) in the leapfrog's
// order of operations (drift, forces from the half-step velocities, kick), undamped, friction too high to
// slide. A constant preload F0 along the branch holds the normal overlap at d0 = F0 / kn, so each mode can
// oscillate about it for ever. The other modes stay at rest to the last bit (the springs' geometry is exact
// along x), so a mode slower than the others can be run at its own limit. One spring is stretched at the start, everything at rest; that excites its
// mode alone (equal spheres: the tangential spring gives both spheres the same moment, the rolling and
// twisting springs opposite ones).
//   - at a small step the oscillation's frequency is the mode's omega (leapfrog: omega (1 + (omega dt)^2/24));
//   - at 0.98 of the leapfrog limit 2/omega the motion stays bounded, at 1.02 it grows.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "contact/contact_law.hpp"
#include "core/plan.hpp"
#include "helpers.hpp"

namespace celldem {
namespace {

using SpringLaw = Law<NormalModel::Linear, TangentialModel::LinearHistory, RollingModel::Sds, TwistingModel::Marshall>;

constexpr double kR = 0.5;                 // [m] both spheres
constexpr double kM = 1.0;                 // [kg] (density 6/pi)
constexpr double kI = 0.4 * kM * kR * kR;  // [kg m^2]
constexpr double kKn = 1.0e4, kKt = 2.0e4, kKroll = 3.0e4;  // [N/m]
constexpr double kOverlap = 1e-3;          // [m] held by the preload

ContactDef contact() {
  ContactDef c;
  c.kn = kKn;
  c.kt = kKt;
  c.rolling = RollingModel::Sds;
  c.rolling_stiffness = kKroll;
  c.twisting = TwistingModel::Marshall;
  c.reference_overlap = kOverlap;
  return c;
}

SampleDef sample() {
  SampleDef s;
  s.diameters = {2.0 * kR};
  s.density = testing::kUnitMassDensity;
  return s;
}

ContactParams params() {
  ContactParams p = contact_params(contact(), Friction{1e9, 1e9});
  p.gamma_roll = 0.0;
  return p;
}

// The mode's coordinate: the stretch of its spring (normal: the overlap's departure from kOverlap).
double coordinate(ContactMode mode, const ContactHistory& h, double overlap) {
  switch (mode) {
    case ContactMode::Normal: return overlap - kOverlap;
    case ContactMode::TangentialRotational: return h.tangential.y;
    case ContactMode::Rolling: return h.rolling.y;
    case ContactMode::Twisting: return h.twist;
  }
  return 0.0;
}

struct Motion {
  double largest = 0.0;  // max |coordinate| over the run
  double start = 0.0;    // |coordinate| at the start
  double omega = 0.0;    // from the mean interval between sign changes [rad/s]
};

// `steps` steps of dt from the mode's spring stretched by `amount`, or until the coordinate passes 1e3 times
// its start.
Motion oscillate(ContactMode mode, double dt, int steps) {
  const ContactParams p = params();
  const double amount = mode == ContactMode::Twisting ? 1e-6 : 1e-7;  // [rad] or [m]: 1e3 times stays in contact
  Vec3 x[2] = {Vec3(0.0, 0.0, 0.0), Vec3(2.0 * kR - kOverlap, 0.0, 0.0)};
  Vec3 v[2] = {Vec3::Zero(), Vec3::Zero()}, w[2] = {Vec3::Zero(), Vec3::Zero()};
  ContactHistory h;
  // The preload: the normal force at rest, to the last bit, pulling the spheres together along their branch
  // (a central force: a fixed direction would make the pair's rigid rotation unstable).
  const double preload =
      evaluate_contact<SpringLaw>(p, x[1] - x[0], kR, kR, Vec3::Zero(), w[0], w[1], h, dt).normal_force;
  if (mode == ContactMode::Normal) x[1].x() -= amount;
  if (mode == ContactMode::TangentialRotational) h.tangential = {0.0, amount, 0.0};
  if (mode == ContactMode::Rolling) h.rolling = {0.0, amount, 0.0};
  if (mode == ContactMode::Twisting) h.twist = amount;

  Motion out;
  out.start = amount;
  double last = amount;
  int crossings = 0;
  double first_crossing = 0.0, last_crossing = 0.0;
  for (int k = 0; k < steps; ++k) {
    for (int i = 0; i < 2; ++i) x[i] += dt * v[i];
    const Vec3 branch = x[1] - x[0];
    const ContactResult c = evaluate_contact<SpringLaw>(p, branch, kR, kR, v[1] - v[0], w[0], w[1], h, dt);
    EXPECT_TRUE(c.touching && !c.sliding) << "step " << k << " dt " << dt << " touching " << c.touching
                                          << " overlap " << 2.0 * kR - branch.norm() << " ft " << c.force.transpose();
    if (!c.touching || c.sliding) break;
    h = {real3(c.tangential), real3(c.rolling), c.twist};
    const Vec3 f1 = c.force - preload * c.normal;
    v[0] += dt / kM * -f1;
    v[1] += dt / kM * f1;
    w[0] += dt / kI * c.torque_i;
    w[1] += dt / kI * c.torque_j;
    const double q = coordinate(mode, h, 2.0 * kR - branch.norm());
    out.largest = std::max(out.largest, std::abs(q));
    if ((q < 0.0) != (last < 0.0)) {
      // The crossing's time by linear interpolation between the two steps.
      const double t = (k + last / (last - q)) * dt;
      if (crossings == 0) first_crossing = t;
      last_crossing = t;
      ++crossings;
    }
    last = q;
    if (out.largest > 1e3 * amount) break;
  }
  if (crossings > 1) out.omega = M_PI * (crossings - 1) / (last_crossing - first_crossing);
  return out;
}

const ModeLimit& limit_of(ContactMode mode) {
  static const CriticalTimeStep limits = critical_time_steps(sample(), contact());
  return limits.modes[static_cast<std::size_t>(mode)];
}

class TimeStepMode : public ::testing::TestWithParam<ContactMode> {};

TEST_P(TimeStepMode, FrequencyMatchesTheFormula) {
  const ModeLimit& l = limit_of(GetParam());
  ASSERT_GT(l.omega, 0.0);
  EXPECT_NEAR(l.time_step, std::sqrt(2.0) / l.omega, 1e-12 * l.time_step);
  const double dt = 0.01 / l.omega;  // ~630 steps a period
  const Motion m = oscillate(GetParam(), dt, 20 * 630);
  EXPECT_NEAR(m.omega, l.omega, 0.01 * l.omega) << l.name;
}

TEST_P(TimeStepMode, BoundedJustBelowTheLeapfrogLimitGrowingJustAbove) {
  const ModeLimit& l = limit_of(GetParam());
  const Motion below = oscillate(GetParam(), 0.98 * 2.0 / l.omega, 5000);
  EXPECT_LT(below.largest, 10.0 * below.start) << l.name;  // the leapfrog's bound: 1/sqrt(1 - 0.98^2) = 5
  const Motion above = oscillate(GetParam(), 1.02 * 2.0 / l.omega, 5000);
  EXPECT_GT(above.largest, 1e3 * above.start) << l.name;
}

std::string mode_name(const ::testing::TestParamInfo<ContactMode>& info) {
  switch (info.param) {
    case ContactMode::Normal: return "Normal";
    case ContactMode::TangentialRotational: return "TangentialRotational";
    case ContactMode::Rolling: return "Rolling";
    case ContactMode::Twisting: return "Twisting";
  }
  return "";
}
INSTANTIATE_TEST_SUITE_P(Modes, TimeStepMode,
                         ::testing::Values(ContactMode::Normal, ContactMode::TangentialRotational,
                                           ContactMode::Rolling, ContactMode::Twisting),
                         mode_name);

// The formulas for two equal spheres of the smallest size (m = 1, r = 0.5, I = 0.1).
TEST(TimeStepModes, ClosedFormsOfTwoEqualSpheres) {
  const double a2 = 0.25 * kOverlap;  // R* d
  EXPECT_NEAR(limit_of(ContactMode::Normal).omega, std::sqrt(2.0 * kKn / kM), 1e-9);
  EXPECT_NEAR(limit_of(ContactMode::TangentialRotational).omega, std::sqrt(7.0 * kKt / kM), 1e-9);
  EXPECT_NEAR(limit_of(ContactMode::Rolling).omega, std::sqrt(1.25 * kKroll / kM), 1e-9);
  EXPECT_NEAR(limit_of(ContactMode::Twisting).omega, std::sqrt(2.0 * 0.5 * kKt * a2 / kI), 1e-9);
  EXPECT_NEAR(limit_of(ContactMode::Normal).time_step, std::sqrt(kM / kKn), 1e-12);  // as before
  EXPECT_NEAR(limit_of(ContactMode::TangentialRotational).time_step, std::sqrt(2.0 * kM / (7.0 * kKt)), 1e-12);
}

TEST(TimeStepModes, TheLimitIsTheSmallestModeOfTheSmallestSpheres) {
  SampleDef s = sample();
  s.diameters = {2.0, 1.0, 1.5};  // the smallest: m = 1
  ContactDef c;
  c.kn = 1e4;
  c.kt = 0.2e4;  // tangential sqrt(2/(7 kt)) = 0.01195 > normal sqrt(1/kn) = 0.01
  EXPECT_EQ(critical_time_steps(s, c).limiting().mode, ContactMode::Normal);
  EXPECT_NEAR(critical_time_step(s, c), 0.01, 1e-12);
  EXPECT_EQ(critical_time_steps(s, c).modes[2].time_step, std::numeric_limits<double>::infinity());  // no rolling
  c.kt = 1e4;  // kt = kn: tangential-rotational, 0.5345 sqrt(m/kn)
  EXPECT_EQ(critical_time_steps(s, c).limiting().mode, ContactMode::TangentialRotational);
  EXPECT_NEAR(critical_time_step(s, c), std::sqrt(2.0 / 7.0) * 0.01, 1e-12);
  c.kt = 0.0;  // no tangential spring: no tangential limit
  c.rolling = RollingModel::Sds;
  c.rolling_stiffness = 1e5;  // sqrt(1.6 m / k_roll) = 0.004
  EXPECT_EQ(critical_time_steps(s, c).limiting().mode, ContactMode::Rolling);
  EXPECT_NEAR(critical_time_step(s, c), std::sqrt(1.6 / 1e5), 1e-12);
}

TEST(TimeStepModes, BoundsNameTheLimitingModeAndTheFraction) {
  SampleDef s = sample();
  ContactDef c;
  c.kn = 1e4;
  c.kt = 1e5;
  const CriticalTimeStep tc = critical_time_steps(s, c);
  const double limit = std::sqrt(2.0 / 7e5);
  const auto findings = time_step_findings(1.5 * limit, tc);
  ASSERT_EQ(findings.size(), 2u);  // above the limit, and above the stable fraction
  EXPECT_TRUE(findings[0].bound->refuse);
  EXPECT_NE(findings[0].message.find("tangential-rotational mode: kt = 1e+05 N/m"), std::string::npos)
      << findings[0].message;
  EXPECT_NE(findings[0].message.find("is 1.5 of the stability limit"), std::string::npos) << findings[0].message;
  EXPECT_FALSE(findings[1].bound->refuse);
  EXPECT_TRUE(time_step_findings(0.9 * limit, tc).empty());
  EXPECT_EQ(time_step_findings(0.95 * limit, tc).size(), 1u);  // warned only
  EXPECT_FALSE(time_step_findings(0.95 * limit, tc)[0].bound->refuse);
  EXPECT_EQ(time_step_findings(0.01 * limit, tc).size(), 1u);  // slow: warned
  ASSERT_EQ(time_step_findings(1e-4 * limit, tc).size(), 2u);  // slow, and below the minimum: refused
  EXPECT_TRUE(time_step_findings(1e-4 * limit, tc)[1].bound->refuse);
}

// kt = kn/10: the normal mode limits, and a packing boils from about 0.9 of its limit (docs/physics.md's sweep):
// refused there, where before only the warning above 0.93 t_c came. kt = kn: the tangential-rotational mode
// limits at 0.53 of the normal mode's limit, so the normal mode's bound lies beyond t_c and changes nothing.
TEST(TimeStepModes, NormalModeBoundRefusesWherePackingsBoil) {
  SampleDef s = sample();
  ContactDef c;
  c.kn = 1e4;
  c.kt = 1e3;
  const CriticalTimeStep tc = critical_time_steps(s, c);
  ASSERT_EQ(tc.limiting().mode, ContactMode::Normal);
  const double normal = tc.modes[0].time_step;
  for (const double f : {0.92, 0.99}) {
    const auto findings = time_step_findings(f * normal, tc);
    ASSERT_FALSE(findings.empty()) << f;
    EXPECT_TRUE(findings[0].bound->refuse) << f;
    EXPECT_STREQ(findings[0].bound->name, "normal_mode");
    EXPECT_NE(findings[0].message.find("of the normal mode's limit"), std::string::npos) << findings[0].message;
    EXPECT_NE(findings[0].message.find("above 0.9 of it"), std::string::npos) << findings[0].message;
  }
  EXPECT_TRUE(time_step_findings(0.89 * normal, tc).empty());
  EXPECT_TRUE(time_step_findings(suggested_time_step(tc), tc).empty());
  c.kt = 1e4;
  const CriticalTimeStep tr = critical_time_steps(s, c);
  ASSERT_EQ(tr.limiting().mode, ContactMode::TangentialRotational);
  for (const double f : {0.5, 0.95, 1.5})
    for (const TimeStepFinding& finding : time_step_findings(f * tr.value(), tr))
      EXPECT_STRNE(finding.bound->name, "normal_mode") << f;
  EXPECT_TRUE(time_step_findings(suggested_time_step(tr), tr).empty() ||
              !time_step_findings(suggested_time_step(tr), tr)[0].bound->refuse);
}

}  // namespace
}  // namespace celldem
