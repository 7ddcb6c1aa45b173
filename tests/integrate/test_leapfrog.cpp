// Time integration (solver/integrate/leapfrog.hpp): drift in a fixed and a deforming cell, the gather of
// pair forces and moments, Newton's third law and angular momentum balance, and damped free motion.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "contact/contact_forces.hpp"
#include "helpers.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

TEST(Leapfrog, DriftMovesByVelocityTimesStepInFixedCell) {
  const double dt = 1e-3;
  const Model model = make_model(testing::model_deck(1e4, 1e4, dt), {0.5});
  const Mat3 h = (Mat3() << 4.0, 1.0, 0.0, 0.0, 5.0, 0.5, 0.0, 0.0, 6.0).finished();
  State s = testing::make_state(h, {0.5}, {Vec3(1.0, 2.0, 3.0)}, 0.1);
  s.particles.velocity[0] = Vec3(0.3, -0.2, 0.1);
  testing::drift(model, h, s);
  EXPECT_NEAR((h * s.particles.scaled[0] - (Vec3(1.0, 2.0, 3.0) + dt * Vec3(0.3, -0.2, 0.1))).norm(), 0.0, 1e-15);
}

// In a deforming cell a particle without fluctuating velocity moves with the affine field (its scaled
// position does not change); one with velocity v' moves by dt v' measured in the mid-step cell.
TEST(Leapfrog, DriftInDeformingCell) {
  const double dt = 1e-3;
  const Model model = make_model(testing::model_deck(1e4, 1e4, dt), {0.5, 0.5});
  const Mat3 h0 = Mat3::Identity() * 4.0;
  State s = testing::make_state(h0, {0.5, 0.5}, {Vec3(1.0, 2.0, 3.0), Vec3(3.0, 1.0, 1.0)}, 0.1);
  s.particles.velocity[1] = Vec3(0.0, 0.0, 2.0);
  const Vec3 s0 = s.particles.scaled[0], s1 = s.particles.scaled[1];
  s.cell.h = Vec3(4.0 * (1 - 1e-3), 4.0, 4.0 * (1 + 2e-3)).asDiagonal();
  testing::drift(model, h0, s);
  EXPECT_EQ(s.particles.scaled[0], s0);
  const Mat3 h_mid = 0.5 * (h0 + s.cell.h);
  EXPECT_NEAR((s.particles.scaled[1] - (s1 + dt * h_mid.inverse() * Vec3(0, 0, 2.0))).norm(), 0.0, 1e-16);
}

// The drift runs on plain arrays in SIMD lanes, with M v' summed as Eigen's 3x3 product sums it: the positions
// are those of `scaled += M * velocity` to the bit, in a general (sheared) cell, over several force blocks and a
// partial one, with and without a neighbour list; the largest move it measures on the way is
// largest_move_since_build's, to the bit. (Half the particles sit near the origin, where the sum's rounding shows.)
TEST(Leapfrog, DriftIsEigensProductToTheBitAndMeasuresTheLargestMove) {
#if defined(EIGEN_VECTORIZE_FMA)
  GTEST_SKIP() << "Eigen fuses its products' multiply-adds in this build (it targets FMA); the drift does not";
#endif
  const double dt = 1e-3;
  const std::size_t n = 2 * kForceBlock + 517;
  const Model model = make_model(testing::model_deck(1e4, 1e4, dt), std::vector<double>(n, 0.01));
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Mat3 h0 = (Mat3() << 4.0, 0.3, -0.2, 0.1, 5.0, 0.4, -0.3, 0.2, 6.0).finished();
  for (const bool built : {true, false}) {
    State s = testing::make_state(h0, std::vector<double>(n, 0.01), std::vector<Vec3>(n, Vec3::Zero()), 0.1);
    for (std::size_t i = 0; i < n; ++i) {
      s.particles.scaled[i] = testing::draw_vec3(u, gen) * (i % 2 == 0 ? 3.0 : 1e-6);
      s.particles.velocity[i] = testing::draw_vec3(u, gen) * std::pow(10.0, 3.0 * u(gen));
    }
    s.cell.h = h0 + (Mat3() << 1e-3, 2e-4, -1e-4, 3e-4, -2e-3, 1e-4, 2e-4, -3e-4, 5e-4).finished();
    s.pairs = PairList{};
    if (built) {  // a list as built a while ago (the drift measures moves only when there is one)
      s.pairs.first.assign(n + 1, 0);
      s.pairs.scaled_at_build.resize(n);
      for (std::size_t i = 0; i < n; ++i)
        s.pairs.scaled_at_build[i] = (s.particles.scaled[i] + testing::draw_vec3(u, gen) * 1e-3).cast<float>();
    }
    const Mat3 step_map = dt * (0.5 * (h0 + s.cell.h)).inverse();
    std::vector<Vec3> expected = s.particles.scaled;
    for (std::size_t i = 0; i < n; ++i) expected[i] += step_map * s.particles.velocity[i];
    const double largest = testing::drift(model, h0, s);
    std::size_t differ = 0;
    for (std::size_t i = 0; i < n; ++i) differ += s.particles.scaled[i] != expected[i];
    EXPECT_EQ(differ, 0u) << "positions that differ from Eigen's product in some bit, of " << n << (built ? "" : " (no list)");
    if (built) {
      EXPECT_EQ(largest, largest_move_since_build(s));
      EXPECT_GT(largest, 0.0);
    } else {
      EXPECT_EQ(largest, std::numeric_limits<double>::infinity());
    }
  }
}

// A free particle under body damping: v_n = keep^n v_0, close to the exact exp(-c t / m).
TEST(Leapfrog, DampedFreeParticleDecaysExponentially) {
  const double dt = 1e-4, kn = 1e4, a = 0.5;
  const Model model = make_model(testing::model_deck(kn, kn, dt, testing::kUnitMassDensity, a, a), {0.5});
  State s = testing::make_state(Mat3::Identity() * 4.0, {0.5}, {Vec3(2, 2, 2)}, 0.1);
  rebuild_pairs(model, s);
  s.particles.velocity[0] = Vec3(1.0, 0.0, 0.0);
  s.particles.spin[0] = Vec3(0.0, 0.0, 10.0);
  const int steps = 500;
  for (int k = 0; k < steps; ++k) testing::gather_and_kick(model, s);
  const double c_over_m = a * 2.0 * std::sqrt(kn);  // m = 1
  EXPECT_NEAR(s.particles.velocity[0].x(), std::exp(-c_over_m * steps * dt), 1e-4);
  EXPECT_NEAR(s.particles.velocity[0].x(), std::pow(model.velocity_keep[0], steps), 1e-14);
  EXPECT_NEAR(s.particles.spin[0].z(), 10.0 * std::pow(model.spin_keep[0], steps), 1e-12);
}

// The gathered net forces obey Newton's third law (they sum to zero) and, with the contact-point lever
// arm, the moments of the contact forces and the contact moments balance (angular momentum is conserved),
// for a cluster of overlapping, moving, spinning spheres in the middle of a large cell.
TEST(Leapfrog, GatherConservesMomentumAndAngularMomentum) {
  std::mt19937_64 gen(8);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 60;
  std::vector<double> r(n);
  std::vector<Vec3> x(n);
  for (int i = 0; i < n; ++i) {
    r[i] = 0.4 + 0.1 * u(gen);
    x[i] = Vec3(10.0, 10.0, 10.0) + testing::draw_vec3(u, gen) * 1.6;
  }
  const Model model = make_model(testing::model_deck(1e4, 8e3, 1e-4), r);
  State s = testing::make_state(Mat3::Identity() * 20.0, r, x, 0.1);
  for (int i = 0; i < n; ++i) {
    s.particles.velocity[i] = testing::draw_vec3(u, gen);
    s.particles.spin[i] = testing::draw_vec3(u, gen) * 20.0;
  }
  rebuild_pairs(model, s);
  for (int k = 0; k < 5; ++k) compute_contact_forces(model, 0.3, s);  // history builds up, some slide
  testing::gather_and_kick(model, s);
  ASSERT_GT(s.touching, 60);
  Vec3 net = Vec3::Zero(), moment = Vec3::Zero();
  double scale = 0.0;
  for (int i = 0; i < n; ++i) {
    const Vec3 xi = s.cell.h * s.particles.scaled[i];
    net += s.particles.force[i];
    moment += xi.cross(s.particles.force[i]) + s.particles.torque[i];
    scale += s.particles.force[i].norm();
  }
  EXPECT_NEAR(net.norm(), 0.0, 1e-12 * scale);
  EXPECT_NEAR(moment.norm(), 0.0, 1e-11 * scale * 10.0);
  // Each particle's net force is the sum of its pair forces (j gets +F, i gets -F).
  std::vector<Vec3> sum(n, Vec3::Zero());
  for_each_pair(s.pairs, [&](Index i, Index q) {
    sum[i] -= s.pairs.force[q];
    sum[s.pairs.neighbor[q]] += s.pairs.force[q];
  });
  for (int i = 0; i < n; ++i) EXPECT_NEAR((sum[i] - s.particles.force[i]).norm(), 0.0, 1e-12 * scale);
}

}  // namespace
}  // namespace celldem
