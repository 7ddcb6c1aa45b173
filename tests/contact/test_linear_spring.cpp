// The linear spring contact law (LinearLaw of solver/contact/contact_law.hpp) driven along prescribed paths:
// normal spring, stick then Coulomb slip, unloading, moments about each centre, and what happens to the
// stored tangential displacement when the contact normal turns.
#include <gtest/gtest.h>

#include <cmath>

#include "contact/contact_law.hpp"

namespace celldem::linear_spring_test {  // (named: the files of test_contact compile as one unit)
namespace {

constexpr double kKn = 1.0e5, kKt = 5.0e4, kMu = 0.5;
constexpr double kRi = 0.5, kRj = 0.3, kOverlap = 0.01;

ContactParams params(MomentArm arm = MomentArm::ContactPoint,
                     TangentialRotation rotation = TangentialRotation::Rotate, double mu = kMu) {
  return ContactParams{kKn, kKt, mu, rotation, arm};
}

// j sits above i along +z with the given overlap.
Vec3 branch_z(double overlap = kOverlap) { return Vec3(0.0, 0.0, kRi + kRj - overlap); }

TEST(LinearSpring, ApartGivesNothingAndForgetsHistory) {
  const ContactResult r = linear_spring_contact(params(), Vec3(0.0, 0.0, kRi + kRj + 1e-9), kRi, kRj,
                                                Vec3(1, 2, 3), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1e-3, 0, 0), 1e-3);
  EXPECT_FALSE(r.touching);
  EXPECT_FALSE(r.sliding);
  EXPECT_EQ(r.force, Vec3::Zero());
  EXPECT_EQ(r.tangential, Vec3::Zero());
  EXPECT_EQ(r.torque_i, Vec3::Zero());
  EXPECT_EQ(r.torque_j, Vec3::Zero());
}

TEST(LinearSpring, NormalForceIsKnTimesOverlapAlongBranch) {
  // An oblique branch: the force on j points from i to j with magnitude kn * overlap.
  const Vec3 dir = Vec3(1.0, -2.0, 2.0) / 3.0;
  for (double overlap : {1e-6, 1e-3, 0.05}) {
    const Vec3 branch = dir * (kRi + kRj - overlap);
    const ContactResult r = linear_spring_contact(params(), branch, kRi, kRj, Vec3::Zero(), Vec3::Zero(),
                                                  Vec3::Zero(), Vec3::Zero(), 1e-3);
    ASSERT_TRUE(r.touching);
    EXPECT_NEAR(r.normal_force, kKn * overlap, 1e-9 * kKn * overlap);
    EXPECT_NEAR((r.force - kKn * overlap * dir).norm(), 0.0, 1e-9 * kKn * overlap);
  }
}

TEST(LinearSpring, NormalRelativeVelocityAddsNoTangentialSpring) {
  const ContactResult r = linear_spring_contact(params(), branch_z(), kRi, kRj, Vec3(0, 0, -3.0), Vec3::Zero(),
                                                Vec3::Zero(), Vec3::Zero(), 1e-3);
  // Zero up to rounding of the unit normal: |v| dt = 3e-3 m, so a few ulps of it at most.
  EXPECT_LT(r.tangential.norm(), 1e-17);
  EXPECT_FALSE(r.sliding);
}

// A one-dimensional elastic-perfectly-plastic slider: the independent reference for the path tests.
struct Slider {
  double kt, limit, s = 0.0;
  bool sliding = false;
  void advance(double ds) {
    s += ds;
    sliding = kt * std::abs(s) > limit;
    if (sliding) s = std::copysign(limit / kt, s);
  }
  double force() const { return -kt * s; }
};

// Tangential relative velocity along x, reversed twice: stick (ft = -kt * slip), slip at mu * fn, elastic
// unloading from the slip limit, slip the other way, and back.
TEST(LinearSpring, StickSlipUnloadFollowsCoulombSlider) {
  const double dt = 1e-4, speed = 0.73;  // 7.3e-5 m per step: the limit (0.01 m) falls between steps
  const double fn = kKn * kOverlap, limit = kMu * fn;
  Slider ref{kKt, limit};
  Vec3 xi = Vec3::Zero();
  int stick_steps = 0, slip_steps = 0;
  const int legs[][2] = {{+1, 180}, {-1, 400}, {+1, 120}};
  for (const auto& leg : legs) {
    for (int k = 0; k < leg[1]; ++k) {
      const Vec3 dv(leg[0] * speed, 0.0, 0.0);
      const ContactResult r =
          linear_spring_contact(params(), branch_z(), kRi, kRj, dv, Vec3::Zero(), Vec3::Zero(), xi, dt);
      ref.advance(leg[0] * speed * dt);
      ASSERT_TRUE(r.touching);
      ASSERT_EQ(r.sliding, ref.sliding) << "leg " << leg[0] << " step " << k;
      EXPECT_NEAR(r.force.x(), ref.force(), 1e-9 * limit) << "step " << k;
      EXPECT_NEAR(r.tangential.x(), ref.s, 1e-12);
      EXPECT_NEAR(r.force.z(), fn, 1e-12 * fn);
      EXPECT_EQ(r.force.y(), 0.0);
      // Never beyond Coulomb; at the limit when sliding, and the stored spring is rescaled with the force.
      EXPECT_LE(std::abs(r.force.x()), limit * (1 + 1e-12));
      if (r.sliding) {
        EXPECT_NEAR(std::abs(r.force.x()), limit, 1e-9 * limit);
        EXPECT_NEAR(r.tangential.norm(), limit / kKt, 1e-12);
        ++slip_steps;
      } else {
        ++stick_steps;
      }
      xi = r.tangential;
    }
  }
  // The path really visited both regimes in both directions (0.01 / 7.3e-5 = 137 steps to the limit).
  EXPECT_GT(stick_steps, 300);
  EXPECT_GT(slip_steps, 100);
}

TEST(LinearSpring, SlipKeepsDirectionOfTrialForce) {
  // A trial displacement well beyond the limit, in an oblique tangential direction.
  const double dt = 1.0;
  const Vec3 dv(0.3, -0.4, 0.0);  // |dv dt| = 0.5 m: far beyond 0.01 m
  const ContactResult r =
      linear_spring_contact(params(), branch_z(), kRi, kRj, dv, Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), dt);
  ASSERT_TRUE(r.sliding);
  const double limit = kMu * kKn * kOverlap;
  const Vec3 ft = r.force - r.force.dot(Vec3::UnitZ()) * Vec3::UnitZ();
  EXPECT_NEAR((ft - (-limit * dv.normalized())).norm(), 0.0, 1e-9 * limit);
  EXPECT_NEAR((r.tangential - limit / kKt * dv.normalized()).norm(), 0.0, 1e-12);
}

TEST(LinearSpring, ZeroFrictionNeverCarriesTangentialForce) {
  const ContactResult r = linear_spring_contact(params(MomentArm::ContactPoint, TangentialRotation::Rotate, 0.0),
                                                branch_z(), kRi, kRj, Vec3(1, 0, 0), Vec3::Zero(), Vec3::Zero(),
                                                Vec3::Zero(), 1e-3);
  EXPECT_TRUE(r.sliding);
  EXPECT_EQ(r.tangential, Vec3::Zero());
  EXPECT_NEAR((r.force - kKn * kOverlap * Vec3::UnitZ()).norm(), 0.0, 1e-12);
}

// Moments: force F on j acts at the contact point c; torque on j = (c - x_j) x F, on i = (c - x_i) x (-F).
// The lever arm is the distance from each centre to the contact point (the middle of the overlap) or the
// plain radius.
TEST(LinearSpring, MomentsAreArmCrossForceForBothArmChoices) {
  const Vec3 dir = Vec3(2.0, 3.0, 6.0) / 7.0;
  const Vec3 branch = dir * (kRi + kRj - kOverlap);
  const Vec3 dv(0.4, -0.1, 0.2), wi(1.0, -2.0, 0.5), wj(-0.3, 0.7, 2.0);
  struct Case {
    MomentArm arm;
    double ai, aj;
  };
  for (const Case& c : {Case{MomentArm::ContactPoint, kRi - 0.5 * kOverlap, kRj - 0.5 * kOverlap},
                        Case{MomentArm::Radius, kRi, kRj}}) {
    for (double dt : {1e-4, 1.0}) {  // sticking, then sliding
      const ContactResult r =
          linear_spring_contact(params(c.arm), branch, kRi, kRj, dv, wi, wj, Vec3::Zero(), dt);
      ASSERT_TRUE(r.touching);
      const Vec3 expected_i = (c.ai * dir).cross(-r.force);
      const Vec3 expected_j = (-c.aj * dir).cross(r.force);
      const double scale = r.force.norm() * kRi;
      EXPECT_NEAR((r.torque_i - expected_i).norm(), 0.0, 1e-12 * scale);
      EXPECT_NEAR((r.torque_j - expected_j).norm(), 0.0, 1e-12 * scale);
      EXPECT_GT(expected_i.norm(), 1e-3 * scale);  // the case is not trivial
    }
  }
}

// The slip of the surfaces, from the rigid-body velocities of the two contact points:
// v_i + w_i x (a_i n) and v_j + w_j x (-a_j n).
TEST(LinearSpring, SpinSlipUsesSurfaceVelocityAtContact) {
  const double dt = 1e-5;
  const Vec3 n = Vec3::UnitZ();
  for (MomentArm arm : {MomentArm::ContactPoint, MomentArm::Radius}) {
    const double ai = arm == MomentArm::ContactPoint ? kRi - 0.5 * kOverlap : kRi;
    const double aj = arm == MomentArm::ContactPoint ? kRj - 0.5 * kOverlap : kRj;
    const Vec3 wi(0.3, 2.0, -7.0), wj(-1.0, 0.5, 4.0), dv(0.05, 0.02, 0.0);
    const ContactResult r =
        linear_spring_contact(params(arm), branch_z(), kRi, kRj, dv, wi, wj, Vec3::Zero(), dt);
    const Vec3 surface_i = wi.cross(ai * n), surface_j = dv + wj.cross(-aj * n);
    Vec3 slip = surface_j - surface_i;
    slip -= slip.dot(n) * n;
    EXPECT_NEAR((r.tangential - slip * dt).norm(), 0.0, 1e-15);
    EXPECT_FALSE(r.sliding);

    // Rolling without slip (a_i w_i = -a_j w_j, no translation) stores nothing.
    const Vec3 wi_roll(0.0, 3.0, 0.0), wj_roll = -ai / aj * wi_roll;
    const ContactResult roll =
        linear_spring_contact(params(arm), branch_z(), kRi, kRj, Vec3::Zero(), wi_roll, wj_roll, Vec3::Zero(), dt);
    EXPECT_NEAR(roll.tangential.norm(), 0.0, 1e-18);
  }
}

// The stored spring xi = xi0 x_hat, built when the normal was z; now the normal has turned by theta in the
// x-z plane. "rotate" keeps |xi| and lays it in the new tangent plane; "project" drops the normal part,
// leaving |xi0| cos(theta).
TEST(LinearSpring, TangentialRotationRotateKeepsLengthProjectDoesNot) {
  const double xi0 = 4e-3, theta = 0.3;
  const Vec3 n(std::sin(theta), 0.0, std::cos(theta));
  const Vec3 in_plane(std::cos(theta), 0.0, -std::sin(theta));  // x_hat turned with the normal
  const Vec3 branch = n * (kRi + kRj - kOverlap);
  const Vec3 xi(xi0, 0.0, 0.0);
  const double big_mu = 100.0;

  const ContactResult rot = linear_spring_contact(params(MomentArm::ContactPoint, TangentialRotation::Rotate, big_mu),
                                                  branch, kRi, kRj, Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), xi, 1e-3);
  EXPECT_NEAR(rot.tangential.norm(), xi0, 1e-15);
  EXPECT_NEAR(rot.tangential.dot(n), 0.0, 1e-15);
  EXPECT_NEAR((rot.tangential - xi0 * in_plane).norm(), 0.0, 1e-15);

  const ContactResult proj = linear_spring_contact(params(MomentArm::ContactPoint, TangentialRotation::Project, big_mu),
                                                   branch, kRi, kRj, Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), xi, 1e-3);
  EXPECT_NEAR(proj.tangential.norm(), xi0 * std::cos(theta), 1e-15);
  EXPECT_NEAR((proj.tangential - xi0 * std::cos(theta) * in_plane).norm(), 0.0, 1e-15);

  // Both give the tangential force -kt xi in the new plane.
  const Vec3 ft = rot.force - rot.force.dot(n) * n;
  EXPECT_NEAR((ft + kKt * rot.tangential).norm(), 0.0, 1e-9);
  EXPECT_NEAR(rot.force.dot(n), kKn * kOverlap, 1e-9);
}

TEST(LinearSpring, UnturnedNormalBothRotationsAgree) {
  const Vec3 xi(1e-3, -2e-3, 0.0), dv(0.1, 0.2, 0.0);
  const ContactResult a = linear_spring_contact(params(MomentArm::ContactPoint, TangentialRotation::Rotate),
                                                branch_z(), kRi, kRj, dv, Vec3::Zero(), Vec3::Zero(), xi, 1e-3);
  const ContactResult b = linear_spring_contact(params(MomentArm::ContactPoint, TangentialRotation::Project),
                                                branch_z(), kRi, kRj, dv, Vec3::Zero(), Vec3::Zero(), xi, 1e-3);
  EXPECT_NEAR((a.tangential - (xi + dv * 1e-3)).norm(), 0.0, 1e-15);
  EXPECT_NEAR((a.tangential - b.tangential).norm(), 0.0, 1e-15);
}

}  // namespace
}  // namespace celldem::linear_spring_test
