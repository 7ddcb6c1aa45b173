// The pair loop (solver/contact/contact_forces.hpp): periodic images, the affine part of the relative
// velocity in a deforming cell, the contact stress and axis stiffness of a lattice against their analytic
// values, and independence of the thread count.
#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <map>
#include <random>

#include "contact/contact_forces.hpp"
#include "contact/contact_forces_reference.hpp"
#include "contact_stress.hpp"
#include "helpers.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/neighbor_list.hpp"
#include "step.hpp"

namespace celldem::contact_forces_test {  // (named: the files of test_contact compile as one unit)
namespace {

using testing::contact_stress;

using testing::find_pair;
using testing::make_state;
using testing::model_deck;

constexpr double kKn = 1.0e4, kKt = 8.0e3, kDt = 1e-4;

// Two spheres of radius 1/2 (dyadic positions, so that both placements give bit-identical branch vectors).
struct PairSetup {
  Mat3 h;
  Vec3 si, sj;  // scaled positions
};

State pair_state(const PairSetup& p, const Mat3& velocity_gradient) {
  State s;
  s.cell.h = p.h;
  s.cell.velocity_gradient = velocity_gradient;
  s.particles.resize(2);
  s.particles.radius = {0.5, 0.5};
  s.particles.scaled = {p.si, p.sj};
  s.particles.velocity = {Vec3(0.25, -0.5, 0.125), Vec3(-0.75, 0.375, 0.5)};
  s.particles.spin = {Vec3(1.5, 2.0, -0.5), Vec3(-3.0, 0.25, 1.0)};
  s.pairs.skin = 0.125;
  s.control.reference.head<3>() = p.h.diagonal();
  s.control.reference_volume = p.h.determinant();
  return s;
}

void expect_same_pair_result(const PairSetup& straddling, const PairSetup& interior) {
  const Mat3 L = (Mat3() << 0.5, 0.25, 0.0, -0.125, -0.25, 0.5, 0.0, 0.75, 0.125).finished();
  const Deck deck = model_deck(kKn, kKt, kDt);
  const Model model = make_model(deck, {0.5, 0.5});
  State a = pair_state(straddling, L), b = pair_state(interior, L);
  rebuild_pairs(model, a);
  rebuild_pairs(model, b);
  const int qa = find_pair(a.pairs, 0, 1), qb = find_pair(b.pairs, 0, 1);
  ASSERT_GE(qa, 0);
  ASSERT_GE(qb, 0);
  EXPECT_NE(a.pairs.image[qa], (PairImage{0, 0, 0}));  // really across the boundary
  compute_contact_forces(model, 0.5, a);
  compute_contact_forces(model, 0.5, b);
  ASSERT_EQ(a.pairs.flags[qa] & kTouching, kTouching);
  ASSERT_GT(a.pairs.force[qa].norm(), 0.0);
  ASSERT_GT(a.pairs.tangential[qa].norm(), 0.0);  // velocities, spins and L all add slip
  EXPECT_EQ(a.pairs.force[qa], b.pairs.force[qb]);
  EXPECT_EQ(a.particles.torque[0], b.particles.torque[0]);
  EXPECT_EQ(a.particles.torque[1], b.particles.torque[1]);  // (one force block: j's share handed over at once)
  EXPECT_EQ(a.pairs.tangential[qa], b.pairs.tangential[qb]);
  EXPECT_EQ(a.pairs.flags[qa], b.pairs.flags[qb]);
  EXPECT_EQ(contact_stress(a), contact_stress(b));
  EXPECT_EQ(a.stiffness.head<3>(), b.stiffness.head<3>());
}

TEST(ContactForces, PairAcrossFaceEqualsSamePairInside) {
  const Mat3 h = Mat3::Identity() * 8.0;
  // Across the x faces: s_j - s_i - 1 = -31/256 (branch -0.96875 m in x).
  const PairSetup straddling{h, Vec3(3.0 / 256, 0.5, 0.5), Vec3(228.0 / 256, 0.5 + 1.0 / 256, 0.5 - 1.0 / 512)};
  const PairSetup interior{h, Vec3(131.0 / 256, 0.5, 0.5), Vec3(100.0 / 256, 0.5 + 1.0 / 256, 0.5 - 1.0 / 512)};
  expect_same_pair_result(straddling, interior);
}

TEST(ContactForces, PairAcrossCornerOfShearedCellEqualsSamePairInside) {
  const Mat3 h = (Mat3() << 8.0, 2.0, 0.0, 0.0, 8.0, 1.0, 0.0, 0.0, 8.0).finished();
  // ds = (-15/256, -17/256, 1/512) through the image (-1, -1, 0).
  const PairSetup straddling{h, Vec3(3.0 / 256, 5.0 / 256, 0.5),
                             Vec3(244.0 / 256, 244.0 / 256, 0.5 + 1.0 / 512)};
  const PairSetup interior{h, Vec3(131.0 / 256, 133.0 / 256, 0.5), Vec3(116.0 / 256, 116.0 / 256, 0.5 + 1.0 / 512)};
  expect_same_pair_result(straddling, interior);
}

// The same physical packing written with particles in different periodic images (scaled positions shifted
// by whole cells, as an unwrapped trajectory leaves them) gives the same forces, pair by pair.
TEST(ContactForces, ForcesDoNotDependOnWhichImageHoldsAParticle) {
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> shift(-2, 2);
  const int n = 150;
  std::vector<double> radius(n);
  for (double& r : radius) r = 0.4 + 0.2 * u(gen);
  const Mat3 h = (Mat3() << 5.0, 0.6, 0.0, 0.0, 5.2, -0.4, 0.0, 0.0, 5.1).finished();
  const Model model = make_model(model_deck(kKn, kKt, kDt), radius);
  State a;
  a.cell.h = h;
  a.cell.velocity_gradient = (Mat3() << 0.1, 0.2, 0.0, 0.0, -0.3, 0.1, 0.05, 0.0, 0.2).finished();
  a.particles.resize(n);
  a.particles.radius = radius;
  a.pairs.skin = 0.1;
  for (int i = 0; i < n; ++i) {
    a.particles.scaled[i] = testing::draw_vec3(u, gen);
    a.particles.velocity[i] = testing::draw_vec3(u, gen) - Vec3(0.5, 0.5, 0.5);
    a.particles.spin[i] = (testing::draw_vec3(u, gen) - Vec3(0.5, 0.5, 0.5)) * 10.0;
  }
  State b = a;
  for (int i = 0; i < n; ++i) b.particles.scaled[i] += testing::draw_vec3(shift, gen);
  rebuild_pairs(model, a);
  rebuild_pairs(model, b);
  compute_contact_forces(model, 0.3, a);
  compute_contact_forces(model, 0.3, b);
  ASSERT_GT(a.touching, 50);  // dense enough to test something (150 spheres, solid fraction ~0.5)
  EXPECT_EQ(a.touching, b.touching);
  for (std::size_t q = 0; q < a.pairs.size(); ++q) {
    if (!(a.pairs.flags[q] & kTouching)) continue;
    const int qb = find_pair(b.pairs, a.pairs.owner_of(q), a.pairs.neighbor[q]);
    ASSERT_GE(qb, 0);
    EXPECT_NEAR((a.pairs.force[q] - b.pairs.force[qb]).norm(), 0.0, 1e-9 * a.pairs.force[q].norm());
    EXPECT_NEAR((a.pairs.tangential[q] - b.pairs.tangential[qb]).norm(), 0.0, 1e-12);
  }
  EXPECT_NEAR((contact_stress(a) - contact_stress(b)).norm(), 0.0, 1e-9 * contact_stress(a).norm());
  // In a sheared cell too, the full tensor's diagonal is the step's normal stress to the bit.
  EXPECT_EQ(Vec3(contact_stress(a).diagonal()), a.stress.head<3>());
}

// Particles at rest in a cell deforming with velocity gradient L: the contact sees the relative velocity
// L * branch of the affine field, so one evaluation stores the tangential part of L * branch * dt.
// With the LAMMPS kinematics the affine field is invisible to the contact: nothing is stored.
TEST(ContactForces, AffineVelocityDifferenceAddsTangentialSlip) {
  const Mat3 L = (Mat3() << 0.3, 1.2, -0.4, 0.2, -0.5, 0.7, -0.9, 0.1, 0.2).finished();
  const Vec3 dir = Vec3(2.0, -3.0, 6.0) / 7.0;
  const Vec3 branch = dir * 0.97;
  const Mat3 h = Mat3::Identity() * 6.0;
  for (Kinematics kin : {Kinematics::Affine, Kinematics::Lammps}) {
    Deck deck = model_deck(kKn, kKt, kDt);
    deck.kinematics = kin;
    const Model model = make_model(deck, {0.5, 0.5});
    State s = make_state(h, {0.5, 0.5}, {Vec3(3.0, 3.0, 3.0), Vec3(3.0, 3.0, 3.0) + branch}, 0.1);
    s.cell.velocity_gradient = L;
    rebuild_pairs(model, s);
    compute_contact_forces(model, 100.0, s);
    const int q = find_pair(s.pairs, 0, 1);
    ASSERT_GE(q, 0);
    ASSERT_TRUE(s.pairs.flags[q] & kTouching);
    const Vec3 lb = L * branch;
    const Vec3 expected = kin == Kinematics::Affine ? Vec3((lb - lb.dot(dir) * dir) * kDt) : Vec3::Zero();
    EXPECT_NEAR((s.pairs.tangential[q] - expected).norm(), 0.0, 1e-15) << "kinematics " << static_cast<int>(kin);
    // The force: kn * overlap along the branch, -kt xi across it.
    const Vec3 f_expected = kKn * 0.03 * dir - kKt * expected;
    EXPECT_NEAR((s.pairs.force[q] - f_expected).norm(), 0.0, 1e-9);
    if (kin == Kinematics::Affine) { EXPECT_GT(expected.norm(), 1e-5); }
  }
}

// advance_slip = false evaluates the forces of the state as it stands: no slip is added.
TEST(ContactForces, NoSlipAddedWhenNotAdvancing) {
  const Model model = make_model(model_deck(kKn, kKt, kDt), {0.5, 0.5});
  State s = make_state(Mat3::Identity() * 6.0, {0.5, 0.5}, {Vec3(3, 3, 3), Vec3(3.9, 3.2, 3.0)}, 0.1);
  s.particles.velocity[1] = Vec3(0.0, 1.0, 0.0);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 1.0, s, /*advance_slip=*/false);
  const int q = find_pair(s.pairs, 0, 1);
  ASSERT_GE(q, 0);
  EXPECT_TRUE(s.pairs.flags[q] & kTouching);
  EXPECT_EQ(s.pairs.tangential[q], Vec3::Zero());
}

// A rectangular lattice of n^3 equal spheres, spacings a_k < 2R, in a periodic cell: each sphere has one
// contact per axis in the half list (3 per sphere), each with force kn (2R - a_k) along the axis and branch
// a_k. sigma = (1/V) sum f (x) l, V = N a_x a_y a_z:
//   sigma_xx = kn (2R - a_x) / (a_y a_z), off-diagonal 0;
//   axis stiffness K_x = (1/V) sum kn (n_x l_x)^2 = kn a_x / (a_y a_z),
// which is also d(sigma_xx)/d(eps_xx) for this lattice, sigma_xx being linear in a_x.
TEST(ContactForces, LatticeStressAndStiffnessMatchAnalytic) {
  const int n = 4;
  const double R = 0.5;
  const Vec3 a(0.99, 0.98, 0.995);
  const Model model = make_model(model_deck(kKn, kKt, kDt), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, a, 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  EXPECT_EQ(s.touching, 3 * n * n * n);
  const Mat3 stress = contact_stress(s);
  for (int k = 0; k < 3; ++k) {
    const double other = a[(k + 1) % 3] * a[(k + 2) % 3];
    const double sigma = kKn * (2 * R - a[k]) / other;
    const double stiffness = kKn * a[k] / other;
    EXPECT_NEAR(stress(k, k), sigma, 1e-9 * sigma) << "axis " << k;
    EXPECT_EQ(s.stress[k], stress(k, k)) << "axis " << k;  // the step's diagonal, to the bit
    EXPECT_GT(stress(k, k), 0.0);  // compression positive
    EXPECT_NEAR(s.stiffness[k], stiffness, 1e-9 * stiffness) << "axis " << k;
    for (int l = 0; l < 3; ++l)
      if (l != k) { EXPECT_NEAR(stress(k, l), 0.0, 1e-9 * sigma); }
  }
  // The affine stiffness against a finite difference of the stress: compress x by eps, affinely.
  const double eps = 1e-4;
  State t = s;
  const Mat3 map = Vec3(1.0 - eps, 1.0, 1.0).asDiagonal();
  t.cell.h = map * s.cell.h;  // scaled positions unchanged: every branch shrinks along x
  compute_contact_forces(model, 0.5, t, false);
  EXPECT_NEAR((t.stress[0] - s.stress[0]) / eps, s.stiffness[0], 1e-6 * s.stiffness[0]);
}

// The FCC lattice (each sphere touching 12 neighbours along <110> at d = a/sqrt(2), overlap 2R - d) under an
// affine tilt of h(0,1) by g12 = g (cell/control.hpp: every branch l -> l - g l_y e_x, scaled positions kept).
// Each contact's force is kn (2R - |l|) along l, so s12 = (1/V) sum f_x l_y is a sum over the six contact
// directions of a sphere's half list, evaluated here by hand. The shear stiffness (1/V) sum kn (n_x l_y)^2 of
// the unsheared lattice is kn / a: only (1, +-1, 0)/sqrt(2) have n_x n_y != 0, (n_x n_y)^2 = 1/4, with
// N/V = 4/a^3 and d^2 = a^2/2. That is the lattice's C44 from its normal springs (the lattice is centrosymmetric,
// so the affine field is its equilibrium): the finite difference of s12 reproduces it to O(overlap/d).
TEST(ContactForces, FccShearStressAndShearStiffnessMatchAnalytic) {
  const int n = 2;
  const double a = 1.0, d = a / std::sqrt(2.0), overlap = 1e-4 * d, R = 0.5 * (d + overlap);
  const Model model = make_model(model_deck(kKn, kKt, kDt), std::vector<double>(4 * n * n * n, R));
  State s = testing::fcc_state(n, R, a, 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s, false);
  const double spheres = 4.0 * n * n * n, volume = std::pow(a * n, 3);
  ASSERT_EQ(s.touching, static_cast<std::int64_t>(6 * spheres));
  for (int k = 0; k < 3; ++k) {  // cubic symmetry: every shear plane alike, and no shear stress unsheared
    EXPECT_NEAR(s.stiffness[3 + k], kKn / a, 1e-9 * kKn / a) << k;
    EXPECT_NEAR(s.stress[3 + k], 0.0, 1e-9 * s.stress[0]) << k;
  }
  const double g = 1e-5;
  State t = s;
  t.cell.h(0, 1) -= g * t.cell.h(1, 1);
  rebuild_pairs(model, t);
  compute_contact_forces(model, 0.5, t, false);
  double expected = 0.0;
  const double r2 = 1.0 / std::sqrt(2.0);
  for (const Vec3& n_c : {Vec3(r2, r2, 0), Vec3(r2, -r2, 0), Vec3(r2, 0, r2), Vec3(r2, 0, -r2), Vec3(0, r2, r2),
                          Vec3(0, r2, -r2)}) {
    const Vec3 l0 = d * n_c;
    const Vec3 l(l0.x() - g * l0.y(), l0.y(), l0.z());
    expected += kKn * (2.0 * R - l.norm()) / l.norm() * l.x() * l.y();
  }
  expected *= spheres / volume;
  EXPECT_GT(expected, 0.0);  // a positive g12 raises the compression-signed s12
  EXPECT_NEAR(t.stress[3 + 0], expected, 1e-9 * expected);
  EXPECT_NEAR(t.stress[3 + 0], contact_stress(t)(0, 1), 1e-12 * s.stress[0]);  // the series' s12
  EXPECT_NEAR(t.stress[3 + 0] / g, s.stiffness[3 + 0], 2e-3 * s.stiffness[3 + 0]);
  EXPECT_NEAR(t.stress[3 + 1], 0.0, 1e-9 * s.stress[0]);
}

// Two evaluations of one scene agree to the bit: reductions, per-pair results, net forces, kicked velocities.
void expect_same_bits(const State& a, const State& b) {
  EXPECT_EQ(a.touching, b.touching);
  EXPECT_EQ(contact_stress(a), contact_stress(b));
  EXPECT_EQ(a.stress.head<3>(), b.stress.head<3>());
  EXPECT_EQ(a.stiffness.head<3>(), b.stiffness.head<3>());
  EXPECT_EQ(a.pairs.force, b.pairs.force);
  EXPECT_EQ(a.pairs.tangential, b.pairs.tangential);
  EXPECT_EQ(a.particles.force, b.particles.force);
  EXPECT_EQ(a.particles.torque, b.particles.torque);
  EXPECT_EQ(a.particles.velocity, b.particles.velocity);
  EXPECT_EQ(a.particles.spin, b.particles.spin);
}

// The reductions, per-pair results and net forces do not depend on the number of threads: 4913 spheres
// make three force blocks (kForceBlock), so blocks are dealt to threads and pairs cross between blocks.
TEST(ContactForces, ResultsIndependentOfThreadCount) {
  const int n = 17;
  ASSERT_GT(static_cast<std::size_t>(n * n * n), 2 * kForceBlock);
  const Model model = make_model(model_deck(kKn, kKt, kDt), std::vector<double>(n * n * n, 0.5));
  State base = testing::jostled_lattice(n, 11, 0.02, 1.0, 5.0);
  base.cell.velocity_gradient = Mat3::Identity() * 0.1;
  const std::vector<State> results = testing::on_thread_counts(model, base, 0.4, {1, 2, 3, 4});
  ASSERT_GT(results[0].touching, 10000);
  ASSERT_GT(results[0].pairs.crossings(), 500u);
  for (std::size_t r = 1; r < results.size(); ++r) expect_same_bits(results[r], results[0]);
}

// The AVX2 gather and the portable one give the same bits: the same chunk data, so the same results. A
// sheared cell (images in every direction) with an affine velocity field, over three force blocks' edges.
TEST(ContactForces, PortableGatherGivesTheSameBits) {
  if (!vector_gather_available()) GTEST_SKIP() << "no AVX2 here: the portable gather is the only one";
  const int n = 17;
  const Model model = make_model(model_deck(kKn, kKt, kDt), std::vector<double>(n * n * n, 0.5));
  State base = testing::jostled_lattice(n, 3, 0.02, 1.0, 5.0);
  base.cell.h(0, 1) = 0.02 * base.cell.h(1, 1);
  base.cell.velocity_gradient = Mat3::Identity() * 0.1;
  base.cell.velocity_gradient(0, 2) = 0.05;
  const State vector_gather = testing::on_thread_counts(model, base, 0.4, {1}).front();
  use_portable_gather(true);
  const State portable = testing::on_thread_counts(model, base, 0.4, {1}).front();
  use_portable_gather(false);
  ASSERT_GT(vector_gather.touching, 5000);
  expect_same_bits(portable, vector_gather);
}

// Every pair reaches both its ends once, whether its owner lies in its neighbour's force block or in an earlier
// one: the net forces and moments equal the plain loop's sums over the pairs
// (contact_forces_reference.hpp), up to the order of the additions.
void expect_net_forces_are_pair_sums(const Model& model, State s) {
  rebuild_pairs(model, s);
  const ReferenceContactForces plain = reference_contact_forces(model, 0.4, s);
  compute_contact_forces(model, 0.4, s);
  gather_forces(s);
  EXPECT_EQ(s.pairs.force, plain.force);
  double largest_force = 0.0, largest_torque = 0.0;
  for (const Vec3& f : plain.net_force) largest_force = std::max(largest_force, f.norm());
  for (const Vec3& t : plain.net_torque) largest_torque = std::max(largest_torque, t.norm());
  ASSERT_GT(largest_torque, 0.0);
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    EXPECT_LT((s.particles.force[i] - plain.net_force[i]).norm(), 1e-12 * largest_force) << i;
    EXPECT_LT((s.particles.torque[i] - plain.net_torque[i]).norm(), 1e-12 * largest_torque) << i;
  }
}

TEST(ContactForces, NetForcesAreTheSumsOfTheirPairs) {
  const int n = 17;  // 4913 spheres: three force blocks, pairs crossing between them
  const State s = testing::jostled_lattice(n, 5, 0.02, 1.0, 5.0);
  const Model model = make_model(model_deck(kKn, kKt, kDt), s.particles.radius);
  State listed = s;
  rebuild_pairs(model, listed);
  ASSERT_GT(listed.pairs.crossings(), 500u);
  expect_net_forces_are_pair_sums(model, s);
}

// The pair loop finds each pair's owner from the list's offsets: rows far longer than a chunk (a large
// sphere among small ones), and owners without pairs (tiny spheres, many in a row, and the last id).
TEST(ContactForces, NetForcesAreTheSumsOfTheirPairsWithLongAndEmptyRows) {
  State s = testing::jostled_lattice(16, 7, 0.02, 1.0, 5.0);
  for (const std::size_t big : {0u, 1u, 1500u, 3000u}) s.particles.radius[big] = 2.4;
  for (std::size_t loner = 100; loner < 140; ++loner) s.particles.radius[loner] = 0.05;  // reach no one
  const Model model = make_model(model_deck(kKn, kKt, kDt), s.particles.radius);
  State listed = s;
  rebuild_pairs(model, listed);
  Index longest = 0, empty = 0;
  for (std::size_t i = 0; i < s.particles.size(); ++i) {
    longest = std::max(longest, listed.pairs.first[i + 1] - listed.pairs.first[i]);
    empty += listed.pairs.first[i + 1] == listed.pairs.first[i];
  }
  ASSERT_GT(longest, 100);  // (chunks of 64 pairs)
  ASSERT_GT(empty, 10);
  expect_net_forces_are_pair_sums(model, s);
}

}  // namespace
}  // namespace celldem::contact_forces_test
