// The fast pair loop (contact/contact_forces.cpp: chunks, SIMD lanes, force blocks, reduction blocks) and the
// kick's per-particle sums (PairList::incoming_pair) against the plain one (contact/contact_forces_reference.hpp), scene by scene.
//
// What agrees to the bit, and why:
// - every pair's force, springs and flags: the same law on the same numbers (the gathered differences and
//   the products with h and L are the same operations), and the law's SIMD lanes round as scalar code does;
// - a particle's net force and moment, when no pair crosses into it from an earlier force block: both add
//   its pairs in list order, starting from zero;
// - the stress sums, when the particles fit in one reduction block (kReductionBlock): both sum in list order.
// What agrees to round-off (1e-12 of the largest value), because the fast path reorders the additions:
// - the net force and moment of a particle that pairs cross into: the fast path adds those pairs last (in
//   its sum), the plain loop where they come in the list (first: their owners have lower ids);
// - the stress sums over more than one reduction block: the fast path sums each block, then the blocks.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

#include "contact/contact_forces.hpp"
#include "contact/contact_forces_reference.hpp"
#include "helpers.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem::contact_forces_reference_test {  // (named: the files of test_contact compile as one unit)
namespace {

using testing::model_deck;

constexpr double kKn = 1.0e4, kKt = 8.0e3, kDt = 1e-4;

// The index of the first element whose bytes differ, or -1.
template <class T>
long first_difference(const std::vector<T>& a, const std::vector<T>& b) {
  if (a.size() != b.size()) return 0;
  for (std::size_t k = 0; k < a.size(); ++k)
    if (std::memcmp(&a[k], &b[k], sizeof(T)) != 0) return static_cast<long>(k);
  return -1;
}
bool same_bits(const Vec3& a, const Vec3& b) { return std::memcmp(a.data(), b.data(), sizeof(Vec3)) == 0; }

double largest_norm(const std::vector<Vec3>& v) {
  double m = 0.0;
  for (const Vec3& x : v) m = std::max(m, x.norm());
  return m;
}

// Evaluates the listed state s with both loops and compares what each leaves (the fast path's net forces
// after gather_forces). history_steps evaluations first grow the springs (rotational ones included).
void expect_agreement(const Model& model, const Friction& friction, State s, int history_steps = 0) {
  rebuild_pairs(model, s);
  for (int k = 0; k < history_steps; ++k) compute_contact_forces(model, friction, s);
  const ReferenceContactForces ref = reference_contact_forces(model, friction, s);
  compute_contact_forces(model, friction, s);
  gather_forces(s);
  const PairList& pl = s.pairs;
  ASSERT_GT(s.touching, 100);

  // Per pair: bit for bit.
  EXPECT_EQ(first_difference(pl.force, ref.force), -1);
  EXPECT_EQ(first_difference(pl.tangential, ref.tangential), -1);
  EXPECT_EQ(first_difference(pl.rolling, ref.rolling), -1);
  EXPECT_EQ(first_difference(pl.twist, ref.twist), -1);
  EXPECT_EQ(first_difference(pl.contact_radius, ref.contact_radius), -1);
  EXPECT_EQ(first_difference(pl.flags, ref.flags), -1);
  EXPECT_EQ(s.touching, ref.touching);

  // Per particle: bit for bit unless pairs cross into it.
  const double force_scale = largest_norm(ref.net_force), torque_scale = largest_norm(ref.net_torque);
  std::size_t crossed_into = 0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    if (pl.incoming_crossing[i] == pl.incoming_first[i + 1]) {
      EXPECT_TRUE(same_bits(s.particles.force[i], ref.net_force[i])) << "particle " << i;
      EXPECT_TRUE(same_bits(s.particles.torque[i], ref.net_torque[i])) << "particle " << i;
    } else {
      ++crossed_into;
      EXPECT_LE((s.particles.force[i] - ref.net_force[i]).norm(), 1e-12 * force_scale) << "particle " << i;
      EXPECT_LE((s.particles.torque[i] - ref.net_torque[i]).norm(), 1e-12 * torque_scale) << "particle " << i;
    }
  }
  EXPECT_EQ(crossed_into > 0, s.particles.size() > kForceBlock);

  // Per cell: bit for bit within one reduction block.
  if (s.particles.size() <= kReductionBlock) {
    EXPECT_TRUE(same_bits(s.stress.head<3>(), ref.stress.head<3>()));
    EXPECT_TRUE(same_bits(s.stiffness.head<3>(), ref.stiffness.head<3>()));
    EXPECT_TRUE(same_bits(s.stiffness.tail<3>(), ref.stiffness.tail<3>()));
    EXPECT_TRUE(same_bits(s.stress.tail<3>(), ref.stress.tail<3>()));
  } else {
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(s.stress[a], ref.stress[a], 1e-12 * ref.stress.head<3>().cwiseAbs().maxCoeff());
      EXPECT_NEAR(s.stiffness[a], ref.stiffness[a], 1e-12 * ref.stiffness.head<3>().cwiseAbs().maxCoeff());
      EXPECT_NEAR(s.stress[3 + a], ref.stress[3 + a], 1e-12 * ref.stress.head<3>().cwiseAbs().maxCoeff());
      EXPECT_NEAR(s.stiffness[3 + a], ref.stiffness[3 + a], 1e-12 * ref.stiffness.tail<3>().cwiseAbs().maxCoeff());
    }
  }
}

// A sheared cell deforming with a full velocity gradient: images in every direction, affine velocities.
State sheared(State s) {
  s.cell.h(0, 1) = 0.02 * s.cell.h(1, 1);
  s.cell.h(2, 0) = -0.01 * s.cell.h(0, 0);
  s.cell.velocity_gradient = Mat3::Identity() * 0.1;
  s.cell.velocity_gradient(0, 2) = 0.05;
  s.cell.velocity_gradient(1, 0) = -0.03;
  return s;
}

Deck rotational_deck() {
  Deck d = model_deck(kKn, kKt, kDt);
  d.contact.normal = NormalModel::Hertz;
  d.contact.tangential = TangentialModel::MindlinRescale;
  d.contact.rolling = RollingModel::Sds;
  d.contact.twisting = TwistingModel::Marshall;
  d.contact.youngs_modulus = 2.0e5;
  d.contact.poisson_ratio = 0.25;
  d.contact.rolling_stiffness = 3.0e3;
  d.contact.rolling_damping = 1.0;
  return d;
}

// 216 spheres: one reduction block, so everything to the bit, the stress sums included.
TEST(ReferencePairLoop, OneReductionBlockAgreesToTheBit) {
  const State s = testing::jostled_lattice(6, 21, 0.02, 1.0, 5.0);
  ASSERT_LE(s.particles.size(), kReductionBlock);
  const Model model = make_model(model_deck(kKn, kKt, kDt), s.particles.radius);
  expect_agreement(model, 0.4, s, 1);
  expect_agreement(model, 0.4, sheared(s), 1);
}

// 1728 spheres: one force block of several reduction blocks; a sheared cell; the LAMMPS kinematics too.
TEST(ReferencePairLoop, OneForceBlock) {
  const State s = sheared(testing::jostled_lattice(12, 22, 0.02, 1.0, 5.0));
  ASSERT_GT(s.particles.size(), kReductionBlock);
  ASSERT_LE(s.particles.size(), kForceBlock);
  Deck deck = model_deck(kKn, kKt, kDt);
  expect_agreement(make_model(deck, s.particles.radius), 0.4, s, 1);
  deck.kinematics = Kinematics::Lammps;
  expect_agreement(make_model(deck, s.particles.radius), 0.4, s, 1);
}

// 2744 spheres: two force blocks, pairs crossing from the first into the second; on 1 and 3 threads.
TEST(ReferencePairLoop, TwoForceBlocksWithCrossings) {
  const State s = sheared(testing::jostled_lattice(14, 23, 0.02, 1.0, 5.0));
  ASSERT_GT(s.particles.size(), kForceBlock);
  const Model model = make_model(model_deck(kKn, kKt, kDt), s.particles.radius);
  State listed = s;
  rebuild_pairs(model, listed);
  ASSERT_GT(listed.pairs.crossings(), 100u);
  const int saved = omp_get_max_threads();
  for (int threads : {1, 3}) {
    SCOPED_TRACE(threads);
    omp_set_num_threads(threads);
    expect_agreement(model, 0.4, s, 2);
  }
  omp_set_num_threads(saved);
}

// Hertz with Mindlin's rescaled springs, rolling resistance and twisting: every history array, over two
// force blocks, after three evaluations (the springs grown, some contacts sliding or rolling at their caps).
TEST(ReferencePairLoop, LawsWithRotationalSprings) {
  const State s = sheared(testing::jostled_lattice(14, 24, 0.02, 1.0, 5.0));
  const Model model = make_model(rotational_deck(), s.particles.radius);
  ASSERT_TRUE(model.contact.rotational_history() && model.contact.radius_history());
  expect_agreement(model, Friction(0.4, 0.1), s, 3);
  Deck linear_rolling = model_deck(kKn, kKt, kDt);  // the linear law with rolling resistance only
  linear_rolling.contact.rolling = RollingModel::Sds;
  linear_rolling.contact.rolling_stiffness = 3.0e3;
  expect_agreement(make_model(linear_rolling, s.particles.radius), Friction(0.4, 0.1), s, 3);
}

}  // namespace
}  // namespace celldem::contact_forces_reference_test
