// Micro and macro measurements (solver/measure/micro.hpp) on sets with known answers: fabric tensors of
// chosen normals, the strong/weak split, mechanical coordination with rattlers removed iteratively, stress
// invariants and the b value, and the measurements of a lattice.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "contact/contact_forces.hpp"
#include "contact_stress.hpp"
#include "helpers.hpp"
#include "integrate/leapfrog.hpp"
#include "measure/micro.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

using testing::contact_stress;

void expect_mat_near(const Mat3& a, const Mat3& b, double tol) {
  EXPECT_NEAR((a - b).norm(), 0.0, tol) << "\n" << a << "\nexpected\n" << b;
}

TEST(Fabric, IsotropicSixNormalsGiveIdentityOverThree) {
  const std::vector<Vec3> n = {Vec3::UnitX(), -Vec3::UnitX(), Vec3::UnitY(), -Vec3::UnitY(), Vec3::UnitZ(), -Vec3::UnitZ()};
  const Fabric f = fabric_of(n, std::vector<double>(6, 1.0));
  expect_mat_near(f.all, Mat3::Identity() / 3.0, 1e-15);
  EXPECT_EQ(f.contacts, 6);
  // All forces equal the mean: none is strong.
  EXPECT_EQ(f.strong_contacts, 0);
  expect_mat_near(f.weak, Mat3::Identity() / 3.0, 1e-15);
  expect_mat_near(f.strong, Mat3::Zero(), 0.0);
}

TEST(Fabric, UniaxialSetHasSingleEntry) {
  const std::vector<Vec3> n = {Vec3::UnitZ(), -Vec3::UnitZ(), Vec3::UnitZ()};
  const Fabric f = fabric_of(n, {1.0, 2.0, 3.0});
  Mat3 expected = Mat3::Zero();
  expected(2, 2) = 1.0;
  expect_mat_near(f.all, expected, 1e-15);
}

TEST(Fabric, RandomNormalsHaveUnitTraceAndSymmetry) {
  std::mt19937_64 gen(5);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Vec3> n;
  std::vector<double> fn;
  for (int k = 0; k < 500; ++k) {
    n.push_back(testing::draw_vec3(g, gen).normalized());
    fn.push_back(std::abs(g(gen)));
  }
  const Fabric f = fabric_of(n, fn);
  EXPECT_NEAR(f.all.trace(), 1.0, 1e-12);
  EXPECT_NEAR(f.strong.trace(), 1.0, 1e-12);
  EXPECT_NEAR(f.weak.trace(), 1.0, 1e-12);
  expect_mat_near(f.all, f.all.transpose(), 0.0);
  // The whole is the contact-weighted mean of its strong and weak parts.
  const double ns = static_cast<double>(f.strong_contacts), nw = 500.0 - ns;
  expect_mat_near(f.all, (ns * f.strong + nw * f.weak) / 500.0, 1e-12);
}

// Strong contacts carry more than the mean normal force. Forces 1, 1, 1, 5 (mean 2): one strong contact,
// along x; three weak, along y, z, z.
TEST(Fabric, StrongWeakSplitAtMeanForce) {
  const std::vector<Vec3> n = {Vec3::UnitY(), Vec3::UnitZ(), -Vec3::UnitZ(), Vec3::UnitX()};
  const Fabric f = fabric_of(n, {1.0, 1.0, 1.0, 5.0});
  EXPECT_EQ(f.contacts, 4);
  EXPECT_EQ(f.strong_contacts, 1);
  expect_mat_near(f.strong, Vec3(1, 0, 0).asDiagonal().toDenseMatrix(), 1e-15);
  expect_mat_near(f.weak, Vec3(0, 1.0 / 3, 2.0 / 3).asDiagonal().toDenseMatrix(), 1e-15);
  expect_mat_near(f.all, Vec3(0.25, 0.25, 0.5).asDiagonal().toDenseMatrix(), 1e-15);
}

TEST(Fabric, EmptySetIsZero) {
  const Fabric f = fabric_of({}, {});
  EXPECT_EQ(f.contacts, 0);
  EXPECT_EQ(f.all, Mat3::Zero());
}

// A tetrahedron (K4: every particle has 3 contacts) with a chain 0-4-5-6 hanging from it and a lone
// particle 7. Only 6 is a rattler at first (one contact); removing it leaves 5 with one, then 4 with one:
// the chain becomes rattlers only by iteration. The core keeps its 6 contacts.
TEST(Coordination, RattlersRemovedIteratively) {
  const std::vector<std::pair<Index, Index>> contacts = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3},
                                                         {0, 4}, {4, 5}, {5, 6}};
  const Coordination c = coordination_of(8, contacts);
  EXPECT_DOUBLE_EQ(c.z, 2.0 * 9 / 8);
  EXPECT_EQ(c.rattlers, 4);  // 4, 5, 6 and 7
  EXPECT_DOUBLE_EQ(c.z_mechanical, 2.0 * 6 / 4);
}

TEST(Coordination, RingHasNoRattlersAndPlantedOnesAreFound) {
  // A ring of 6: everyone has exactly 2 contacts, nobody is removed.
  std::vector<std::pair<Index, Index>> ring;
  for (Index i = 0; i < 6; ++i) ring.emplace_back(std::min<Index>(i, (i + 1) % 6), std::max<Index>(i, (i + 1) % 6));
  Coordination c = coordination_of(6, ring);
  EXPECT_EQ(c.rattlers, 0);
  EXPECT_DOUBLE_EQ(c.z, 2.0);
  EXPECT_DOUBLE_EQ(c.z_mechanical, 2.0);
  // Planted: particle 6 touches one ring member, 7 touches nothing.
  ring.emplace_back(2, 6);
  c = coordination_of(8, ring);
  EXPECT_EQ(c.rattlers, 2);
  EXPECT_DOUBLE_EQ(c.z, 2.0 * 7 / 8);
  EXPECT_DOUBLE_EQ(c.z_mechanical, 2.0);
  // A single open chain collapses entirely.
  c = coordination_of(4, {{0, 1}, {1, 2}, {2, 3}});
  EXPECT_EQ(c.rattlers, 4);
  EXPECT_EQ(c.z_mechanical, 0.0);
}

// Stress invariants of diag(3, 2, 1) x 100 kPa: p = 200 kPa, q = sqrt(((s1-s2)^2 + (s2-s3)^2 + (s3-s1)^2)/2)
// = sqrt(3) x 100 kPa, sin(phi) = (s1 - s3)/(s1 + s3) = 1/2. The same in any frame.
TEST(StressInvariants, KnownTensorInAnyFrame) {
  const Mat3 d = Vec3(3e5, 2e5, 1e5).asDiagonal();
  const StressInvariants inv = stress_invariants(d);
  EXPECT_NEAR(inv.p, 2e5, 1e-9);
  EXPECT_NEAR(inv.q, std::sqrt(3.0) * 1e5, 1e-9);
  EXPECT_NEAR(inv.sin_phi, 0.5, 1e-14);
  const Mat3 R = Eigen::AngleAxisd(0.7, Vec3(1.0, 2.0, -0.5).normalized()).toRotationMatrix();
  const StressInvariants rot = stress_invariants(R * d * R.transpose());
  EXPECT_NEAR(rot.p, 2e5, 1e-9);
  EXPECT_NEAR(rot.q, std::sqrt(3.0) * 1e5, 1e-9);
  EXPECT_NEAR(rot.sin_phi, 0.5, 1e-12);
  // Principal values in another order give the same sin(phi) (largest and smallest, not s11 and s33).
  EXPECT_NEAR(stress_invariants(Vec3(1e5, 3e5, 2e5).asDiagonal()).sin_phi, 0.5, 1e-14);
  // Isotropic: no deviator.
  const StressInvariants iso = stress_invariants(Mat3::Identity() * 5e4);
  EXPECT_NEAR(iso.q, 0.0, 1e-9);
  EXPECT_NEAR(iso.sin_phi, 0.0, 1e-15);
}

TEST(StressInvariants, BValue) {
  EXPECT_DOUBLE_EQ(b_value(3.0, 2.0, 1.0), 0.5);
  EXPECT_DOUBLE_EQ(b_value(3.0, 1.0, 1.0), 0.0);  // triaxial compression
  EXPECT_DOUBLE_EQ(b_value(3.0, 3.0, 1.0), 1.0);  // triaxial extension
  EXPECT_DOUBLE_EQ(b_value(4e5, 1.75e5, 1e5), 0.25);
  EXPECT_TRUE(std::isnan(b_value(2.0, 5.0, 2.0)));
}

// A simple cubic lattice of n^3 spheres (spacing a < 2R) in equilibrium: Z = 6 with no rattlers, fabric
// I/3, every contact normal force kn (2R - a) equal (none strong), void ratio a^3 / (4/3 pi R^3) - 1, no
// net force on any sphere, nothing sliding.
TEST(LatticeMeasurements, SimpleCubic) {
  const int n = 4;
  const double R = 0.5, a = 0.98, kn = 1e4;
  const Model model = make_model(testing::model_deck(kn, kn, 1e-4), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, Vec3(a, a, a), 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  testing::gather_and_kick(model, s);
  const ContactMeasures m = measure_contacts(model, s);
  const double delta0 = 2 * R - a;
  for (const Coordination& z : {m.coordination, m.coordination_frictionless}) {
    EXPECT_DOUBLE_EQ(z.z, 6.0);
    EXPECT_DOUBLE_EQ(z.z_mechanical, 6.0);
    EXPECT_EQ(z.rattlers, 0);
  }
  const Fabric& f = m.fabric;
  EXPECT_EQ(f.contacts, 3 * n * n * n);
  expect_mat_near(f.all, Mat3::Identity() / 3.0, 1e-12);
  EXPECT_NEAR(f.mean_normal_force, kn * delta0, 1e-9);
  // Love-Weber: three contacts per sphere, each f = kn delta along a branch a, in a volume a^3 per sphere.
  expect_mat_near(m.stress, Mat3::Identity() * kn * delta0 / (a * a), 1e-9);
  EXPECT_NEAR(m.elastic_energy, 3 * n * n * n * 0.5 * kn * delta0 * delta0, 1e-9);  // no tangential springs yet
  EXPECT_NEAR(void_ratio(model, s), a * a * a / (4.0 / 3.0 * M_PI * R * R * R) - 1.0, 1e-12);
  EXPECT_NEAR(m.unbalanced_force, 0.0, 1e-9);
  EXPECT_EQ(m.sliding, 0);
  EXPECT_EQ(m.sliding_fraction, 0.0);
  EXPECT_NEAR(m.kinetic_energy, 0.0, 1e-20);  // rounding-level forces only

  // One sphere pushed off its site by u along x. Its x neighbours' overlaps become delta +- u; its four
  // transverse neighbours sit at d = sqrt(a^2 + u^2) with overlap dt = 2R - d along tilted normals.
  //   sphere 0:        |net| = 2 kn u - 4 kn dt u / d
  //   x neighbours:    |net| = kn u each
  //   transverse ones: |net| = kn sqrt((dt u / d)^2 + (dt a / d - delta)^2) each
  // over the mean normal force kn (192 delta + 4 (dt - delta)) / 192.
  const double u = 0.005, delta = 2 * R - a, d = std::sqrt(a * a + u * u), dt = 2 * R - d;
  State t = s;
  t.particles.scaled[0] += t.cell.h.inverse() * Vec3(u, 0.0, 0.0);
  compute_contact_forces(model, 0.5, t, false);
  testing::gather_and_kick(model, t);
  const double net = (2 * kn * u - 4 * kn * dt * u / d) + 2 * kn * u +
                     4 * kn * std::hypot(dt * u / d, dt * a / d - delta);
  const double mean_normal = kn * (192 * delta + 4 * (dt - delta)) / 192.0;
  EXPECT_NEAR(measure_contacts(model, t).unbalanced_force, net / 64.0 / mean_normal, 1e-9);
  EXPECT_NEAR(t.particles.force[0].x(), -(2 * kn * u - 4 * kn * dt * u / d), 1e-9);
}

// Particle stresses and net forces: on the simple cubic lattice each sphere carries kn delta a / V_p on the
// diagonal (two contacts along each axis, each kn delta times half the branch a) and nothing off it; with one
// sphere displaced, the particles' V_p sigma_p add up to the cell's V sigma and the net forces are the
// kick's sums.
TEST(ParticleStress, LatticeValueAndSumOverParticlesIsTheCellStress) {
  const int n = 4;
  const double R = 0.5, a = 0.98, kn = 1e4, delta = 2 * R - a, vp = 4.0 / 3.0 * M_PI * R * R * R;
  const Model model = make_model(testing::model_deck(kn, kn, 1e-4), std::vector<double>(n * n * n, R));
  State s = testing::lattice_state(n, R, Vec3(a, a, a), 0.05);
  rebuild_pairs(model, s);
  compute_contact_forces(model, 0.5, s);
  for (const Mat3& sigma : particle_stresses(s)) expect_mat_near(sigma, Mat3::Identity() * kn * delta * a / vp, 1e-9);
  for (const Vec3& f : net_contact_forces(s)) EXPECT_LT(f.norm(), 1e-9);

  State t = s;
  t.particles.scaled[0] += t.cell.h.inverse() * Vec3(0.005, 0.002, -0.001);
  compute_contact_forces(model, 0.5, t, false);
  testing::gather_and_kick(model, t);
  Mat3 sum = Mat3::Zero();
  const std::vector<Mat3> sigma = particle_stresses(t);
  for (std::size_t i = 0; i < sigma.size(); ++i) sum += vp * sigma[i];
  const Mat3 cell = t.cell.volume() * contact_stress(t);
  expect_mat_near(sum, cell, 1e-12 * cell.norm());
  EXPECT_GT((sigma[0] - sigma[5]).norm(), 1e-3 * sigma[5].norm());  // the displaced sphere differs
  const std::vector<Vec3> net = net_contact_forces(t);
  for (std::size_t i = 0; i < net.size(); ++i) EXPECT_LT((net[i] - t.particles.force[i]).norm(), 1e-9) << i;
  EXPECT_GT(net[0].norm(), 1.0);
}

// The one walk against sums written out one quantity at a time, on a jostled lattice of 343 spheres (two
// reduction blocks of owners) in a sheared cell with friction, after steps with slip, so that contacts slide and the
// tangential springs hold energy. The stress is contact_stress's and its diagonal the pair loop's to the bit.
TEST(ContactMeasures, OneWalkMatchesSeparateSums) {
  const int n = 7;
  const double kn = 1e4, kt = 5e3;
  const Model model = make_model(testing::model_deck(kn, kt, 1e-3), std::vector<double>(n * n * n, 0.5));
  State s = testing::jostled_lattice(n, 17, 0.01, 0.5, 0.5);
  // A sheared cell: every row of h has off-diagonal terms (Eigen's h * ds sums the third row in another
  // order than the pair loop, which the stress must follow).
  s.cell.h(0, 1) = 0.03 * s.cell.h(0, 0), s.cell.h(1, 2) = -0.02 * s.cell.h(1, 1);
  s.cell.h(2, 0) = 0.04 * s.cell.h(2, 2), s.cell.h(2, 1) = 0.01 * s.cell.h(2, 2);
  rebuild_pairs(model, s);
  for (int k = 0; k < 5; ++k) compute_contact_forces(model, 0.2, s);
  testing::gather_and_kick(model, s);
  const ContactMeasures m = measure_contacts(model, s);

  EXPECT_EQ(m.stress, contact_stress(s));
  EXPECT_EQ(Vec3(m.stress.diagonal()), s.stress.head<3>());

  const PairList& pl = s.pairs;
  const Particles& p = s.particles;
  std::int64_t touching = 0, sliding = 0;
  double normal_sum = 0.0, spring_energy = 0.0, kinetic = 0.0, net = 0.0;
  Mat3 fabric = Mat3::Zero();
  std::vector<std::pair<Index, Index>> contacts;
  for (std::size_t q = 0; q < pl.size(); ++q) {
    if (!(pl.flags[q] & kTouching)) continue;
    const Index i = pl.owner_of(q), j = pl.neighbor[q];
    const Vec3 image(pl.image[q][0], pl.image[q][1], pl.image[q][2]);
    const Vec3 l = s.cell.h * (p.scaled[j] - p.scaled[i] + image);
    const Vec3 normal = l / l.norm();
    const double fn = pl.force[q].dot(normal);
    ++touching;
    sliding += (pl.flags[q] & kSliding) != 0;
    normal_sum += fn;
    fabric += normal * normal.transpose();
    spring_energy += fn * fn / (2 * kn) + (pl.force[q] - fn * normal).squaredNorm() / (2 * kt);
    contacts.emplace_back(i, j);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double mass = model.mass_of(p.radius[i]), inertia = 0.4 * mass * p.radius[i] * p.radius[i];
    kinetic += 0.5 * mass * p.velocity[i].squaredNorm() + 0.5 * inertia * p.spin[i].squaredNorm();
    net += p.force[i].norm();
  }
  ASSERT_GT(touching, 3 * n * n * n / 2);
  ASSERT_GT(sliding, 0);
  EXPECT_EQ(m.fabric.contacts, touching);
  EXPECT_EQ(m.sliding, sliding);
  EXPECT_EQ(m.sliding_fraction, static_cast<double>(sliding) / static_cast<double>(touching));
  EXPECT_EQ(touching, s.touching);
  expect_mat_near(m.fabric.all, fabric / static_cast<double>(touching), 1e-12);
  EXPECT_NEAR(m.fabric.mean_normal_force, normal_sum / touching, 1e-12 * normal_sum / touching);
  EXPECT_NEAR(m.elastic_energy, spring_energy, 1e-12 * spring_energy);
  EXPECT_NEAR(m.kinetic_energy, kinetic, 1e-12 * kinetic);
  EXPECT_NEAR(m.unbalanced_force, (net / p.size()) / (normal_sum / touching), 1e-12);
  const Coordination z2 = coordination_of(p.size(), contacts, kFrictionalRattler);
  const Coordination z4 = coordination_of(p.size(), contacts, kFrictionlessRattler);
  EXPECT_EQ(m.coordination.z, 2.0 * touching / p.size());
  EXPECT_EQ(m.coordination.z_mechanical, z2.z_mechanical);
  EXPECT_EQ(m.coordination_frictionless.z_mechanical, z4.z_mechanical);
  EXPECT_EQ(m.coordination_frictionless.rattlers, z4.rattlers);
  EXPECT_GE(m.coordination_frictionless.rattlers, m.coordination.rattlers);
}

TEST(Measurements, KineticEnergyOfSolidSpheres) {
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), {0.5, 0.25});
  State s = testing::make_state(Mat3::Identity() * 10.0, {0.5, 0.25}, {Vec3(1, 1, 1), Vec3(5, 5, 5)}, 0.1);
  s.particles.velocity = {Vec3(1.0, 2.0, 2.0), Vec3::Zero()};
  s.particles.spin = {Vec3::Zero(), Vec3(0.0, 0.0, 4.0)};
  const double m0 = 1.0, m1 = 1.0 / 8.0;
  const double expected = 0.5 * m0 * 9.0 + 0.5 * (0.4 * m1 * 0.0625) * 16.0;
  EXPECT_NEAR(measure_contacts(model, s).kinetic_energy, expected, 1e-12);
}

// The soft start's dilation for two spheres that overlap (d < r_i + r_j): (r_i + r_j - f r_min) / d, also across
// the periodic boundary; after it the overlap is exactly f r_min. Spheres apart need none (factor 1).
TEST(Measurements, OverlapDilationOfTwoSpheres) {
  const std::vector<double> r = {0.5, 0.25};
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-4), r);
  for (const Vec3& first : {Vec3(2.0, 5.0, 5.0), Vec3(0.1, 5.0, 5.0)}) {  // the second lies across x = 0
    const double d = 0.5;                                                  // overlap 0.25 = 1.0 r_min
    Vec3 second = first - Vec3(d, 0.0, 0.0);
    if (second.x() < 0.0) second.x() += 10.0;
    State s = testing::make_state(Mat3::Identity() * 10.0, r, {first, second}, 0.1);
    rebuild_pairs(model, s);
    const double f = 0.01;
    const double factor = overlap_dilation(s, f);
    EXPECT_NEAR(factor, (0.75 - f * 0.25) / d, 1e-14);
    EXPECT_NEAR(factor, 1.495, 1e-14);
    EXPECT_NEAR(overlaps(s, 0.05).worst, 1.0, 1e-14);
    s.cell.h *= factor;
    const Overlaps after = overlaps(s, 0.05);
    EXPECT_EQ(after.count, 1);
    EXPECT_NEAR(after.worst, f, 1e-12);
    s.cell.h *= 1.01;
    EXPECT_EQ(overlap_dilation(s, f), 1.0);  // apart: nothing to do
  }
}

}  // namespace
}  // namespace celldem
