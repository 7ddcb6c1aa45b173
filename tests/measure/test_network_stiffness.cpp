// The stiffness of the contact network (measure/network_stiffness.hpp): an FCC lattice against its analytic
// elastic constants, an unstable lattice, and the laws it refuses (a random packing against celldem's own strain
// probes: test_network_stiffness_packing.cpp).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "contact_stress.hpp"
#include "helpers.hpp"
#include "io/deck_reader.hpp"
#include "io/state_file.hpp"
#include "measure/micro.hpp"
#include "measure/network_stiffness.hpp"
#include "core/plan.hpp"
#include "run/runner.hpp"

namespace celldem {
namespace {

using testing::model_deck;

// ---- FCC: the analytic lattice stiffness ----
// Equal spheres of radius r on an FCC lattice of constant a, each touching its 12 neighbours along <110> at
// d = a / sqrt(2) with normal force f = kn (2r - d). Per unit volume there are 4 / a^3 contacts along each of
// the 6 directions n = (+-1, 1, 0)/sqrt(2) and permutations (rho = 4 / a^3 below), and the stress is isotropic,
// p = (1/V) sum f d / 3 = 2 rho f d. Every sphere is a centre of symmetry, so an affine strain leaves each
// with no net force and (sum over its contacts of n x eps n = 0 for a symmetric eps and this cubic set) no
// net moment: nothing relaxes. With the tangent of sigma = (1/V) sum f (x) l under l -> (I - eps) l,
// V -> V (1 - tr eps) (the header's derivation), per contact
//   d sigma = kn d^2 n n (n.eps n) - 2 f d sym(n (x) eps n) + g f d [n n (n.eps n) - sym(eps n (x) n)]
//             + kt d^2 sym((I - nn) eps n (x) n),   plus p tr(eps),
// g = 1 with the geometric term (normal springs only), 0 without (with tangential springs), and the sums over
// the six directions (sum n1^4 = 1, sum n1^2 n2^2 = 1/2, sum n1^2 = 2) give
//   g = 1, kt = 0:  C11 = rho (kn d^2 - f d),  C12 = rho (kn d^2 / 2 + 5 f d / 2),  C44 = rho (kn d^2 - 3 f d) / 2
//   g = 0:          C11 = rho (kn + kt) d^2,   C12 = rho ((kn - kt) d^2 / 2 + 2 f d),  C44 = rho ((kn + kt) d^2 - 2 f d) / 2
// (without prestress and kt: C11 = 2 kn / a, C12 = C44 = kn / a, the nearest-neighbour spring lattice).
struct FccExpectation {
  double c11, c12, c44;
};

FccExpectation fcc_constants(double kn, double kt, double radius, double a, bool geometric) {
  const double d = a / std::sqrt(2.0), f = kn * (2.0 * radius - d), rho = 4.0 / (a * a * a);
  if (geometric)
    return {rho * (kn * d * d - f * d), rho * (kn * d * d / 2.0 + 2.5 * f * d), rho * (kn * d * d - 3.0 * f * d) / 2.0};
  return {rho * (kn + kt) * d * d, rho * ((kn - kt) * d * d / 2.0 + 2.0 * f * d),
          rho * ((kn + kt) * d * d - 2.0 * f * d) / 2.0};
}

Stiffness6 cubic_stiffness(const FccExpectation& e) {
  Stiffness6 c = Stiffness6::Zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c(i, j) = i == j ? e.c11 : e.c12;
  for (int i = 3; i < 6; ++i) c(i, i) = e.c44;
  return c;
}

void expect_fcc(bool tangential, double kt) {
  const double kn = 1.0e4, a = 1.0, d = a / std::sqrt(2.0);
  const double radius = 0.5 * d * (1.0 + 2e-3);  // overlap 2e-3 of the contact distance
  State state = testing::fcc_state(3, radius, a, 0.05);
  const Model model = make_model(model_deck(kn, kt, 1e-4), std::vector<double>(state.particles.size(), radius));
  rebuild_pairs(model, state);
  const NetworkStiffness network = network_stiffness(model, state, tangential);
  EXPECT_EQ(network.contacts, 6 * static_cast<int>(state.particles.size()));
  EXPECT_EQ(network.rattlers, 0);
  const FccExpectation e = fcc_constants(kn, kt, radius, a, !tangential);
  const Stiffness6 expected = cubic_stiffness(e);
  const double scale = expected.cwiseAbs().maxCoeff();
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(network.affine(i, j), expected(i, j), 1e-9 * scale) << "affine (" << i << ", " << j << ")";
      EXPECT_NEAR(network.relaxed(i, j), expected(i, j), 1e-9 * scale) << "relaxed (" << i << ", " << j << ")";
    }
  // The prestress terms (multiples of rho f d) are a thousand times the tolerance: the check resolves them.
  const double force = kn * (2.0 * radius - d);
  EXPECT_GT(4.0 / (a * a * a) * force * d, 1e3 * 1e-9 * scale);
}

TEST(NetworkStiffness, FccLatticeWithNormalSpringsMatchesItsAnalyticConstants) { expect_fcc(false, 0.0); }

TEST(NetworkStiffness, FccLatticeWithTangentialSpringsMatchesItsAnalyticConstants) { expect_fcc(true, 0.6e4); }

// ---- the laws it refuses ----

TEST(NetworkStiffness, RefusesAnotherContactLawNamingIt) {
  State state = testing::fcc_state(2, 0.36, 1.0, 0.05);
  Model base = make_model(model_deck(1e4, 1e4, 1e-4), std::vector<double>(state.particles.size(), 0.36));
  rebuild_pairs(base, state);
  const auto message = [&](const Model& model) {
    try {
      network_stiffness(model, state, true);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("(nothing thrown)");
  };
  Model hertz = base;
  hertz.contact.normal = NormalModel::Hertz;
  EXPECT_NE(message(hertz).find("contact.normal \"hertz\""), std::string::npos) << message(hertz);
  Model mindlin = base;
  mindlin.contact.tangential = TangentialModel::Mindlin;
  EXPECT_NE(message(mindlin).find("contact.tangential \"mindlin\""), std::string::npos) << message(mindlin);
  Model rolling = base;
  rolling.contact.rolling = RollingModel::Sds;
  EXPECT_NE(message(rolling).find("contact.rolling \"sds\""), std::string::npos) << message(rolling);
  Model twisting = base;
  twisting.contact.twisting = TwistingModel::Marshall;
  EXPECT_NE(message(twisting).find("contact.twisting \"marshall\""), std::string::npos) << message(twisting);
  EXPECT_NO_THROW(network_stiffness(base, state, true));
}


// A simple cubic lattice under compression: with normal springs only, a sphere moved across its six contacts
// meets only the prestress's negative stiffness -f/d (the lattice buckles), so the network has no relaxed
// stiffness and says so; sticking tangential springs hold it. One sphere is moved off its site (by 1e-4 of the
// spacing, all its contacts kept) so that a strain loads the lattice's sites, not only round-off.
TEST(NetworkStiffness, AnUnstableNetworkIsAnError) {
  const double radius = 0.5 * (1.0 + 1e-3);
  State state = testing::lattice_state(3, radius, Vec3(1.0, 1.0, 1.0), 0.05);
  state.particles.scaled[13] += state.cell.h.inverse() * Vec3(1e-4, 2e-4, 0.0);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), std::vector<double>(state.particles.size(), radius));
  rebuild_pairs(model, state);
  try {
    network_stiffness(model, state, false);
    ADD_FAILURE() << "no error for a buckling lattice";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not stable"), std::string::npos) << e.what();
  }
  const NetworkStiffness held = network_stiffness(model, state, true);
  EXPECT_EQ(held.rattlers, 0);
  EXPECT_GT(held.relaxed(3, 3), 0.0);
}

// ---- the time step from the network's spectrum ----

// Two equal spheres in contact (mass m): the network's modes are the pair's, normal omega^2 = 2 kn / m and
// tangential-rotational 7 kt / m (lever arm r: the contact point's slip du + r n x (theta_i + theta_j) against
// the reduced mass m/2 and the inertia 2/5 m r^2 of each), so the network's leapfrog limit 2 / omega_max is
// core/plan's pair formula, whose t_c is sqrt(2) / omega of the limiting mode: 2 / omega_max = sqrt(2) t_c.
void expect_pair(double kn, double kt, MomentArm arm) {
  Deck deck = model_deck(kn, kt, 1e-4);
  deck.contact.moment_arm = arm;
  const double radius = 0.5;  // diameter 1: mass 1 kg at the unit density
  const Vec3 normal = Vec3(1.0, 2.0, -0.5).normalized();
  State state = testing::make_state(Mat3::Identity() * 10.0, {radius, radius},
                                    {Vec3(5.0, 5.0, 5.0), Vec3(5.0, 5.0, 5.0) + normal * (2 * radius * (1 - 1e-3))}, 0.05);
  const Model model = make_model(deck, state.particles.radius);
  rebuild_pairs(model, state);
  const NetworkTimeStep t = network_time_step_limit(model, state);
  const double omega = std::sqrt(std::max(2.0 * kn, 7.0 * kt) / 1.0);
  EXPECT_EQ(t.contacts, 1);
  EXPECT_EQ(t.unknowns, 12);
  EXPECT_NEAR(t.omega_max, omega, 1e-9 * omega);
  EXPECT_NEAR(t.limit, std::sqrt(2.0) * critical_time_steps(deck.sample, deck.contact).value(), 1e-9 * t.limit);
  EXPECT_NEAR(t.pair_limit, t.limit, 1e-9 * t.limit);
  EXPECT_NEAR(t.unit, std::sqrt(1.0 / kn), 1e-12);
  EXPECT_GE(t.gershgorin_omega, t.omega_max * (1 - 1e-12));
  EXPECT_LE(t.residual_bound, kLanczosTolerance);
}

TEST(NetworkTimeStep, TwoSpheresGiveThePairFormulaNormalMode) { expect_pair(1e4, 1e3, MomentArm::ContactPoint); }
TEST(NetworkTimeStep, TwoSpheresGiveThePairFormulaTangentialMode) { expect_pair(1e4, 1e4, MomentArm::Radius); }

// A jostled lattice of 64 spheres (each with about six contacts at different overlaps and directions): the
// Lanczos iteration's omega_max^2 is the largest eigenvalue of the same matrix by Eigen's dense solver, the
// Gershgorin bound lies above it, and the network is stiffer than a pair (a sphere pressed by several).
TEST(NetworkTimeStep, LanczosAgreesWithTheDenseSolver) {
  State state = testing::jostled_lattice(4, 17, 0.01, 0.0, 0.0);
  const Model model = make_model(model_deck(1e4, 1e3, 1e-4), std::vector<double>(state.particles.size(), 0.5));
  rebuild_pairs(model, state);
  const Eigen::SparseMatrix<double> a = network_dynamic_matrix(model, state);
  ASSERT_EQ(a.rows(), 6 * 64);
  const Eigen::MatrixXd dense(a);
  EXPECT_NEAR((dense - dense.transpose()).cwiseAbs().maxCoeff(), 0.0, 1e-12 * dense.cwiseAbs().maxCoeff());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(dense, Eigen::EigenvaluesOnly);
  const double largest = eigen.eigenvalues().maxCoeff();
  EXPECT_GT(eigen.eigenvalues().minCoeff(), -1e-9 * largest);  // positive semidefinite
  int iterations = 0;
  double bound = 0.0;
  EXPECT_NEAR(largest_eigenvalue(a, kLanczosTolerance, &iterations, &bound), largest, 1e-9 * largest);
  EXPECT_LT(iterations, 6 * 64);
  const NetworkTimeStep t = network_time_step_limit(model, state);
  EXPECT_NEAR(t.omega_max, std::sqrt(largest), 1e-9 * std::sqrt(largest));
  EXPECT_GE(t.gershgorin_omega * t.gershgorin_omega, largest * (1 - 1e-12));
  EXPECT_GT(t.contacts, 150);
  EXPECT_LT(t.limit, t.pair_limit);
}

// ---- analytic chains and pairs: every spring of the spectrum ----

// A periodic chain of N (even) equal spheres of mass m along x, each touching its two neighbours at the same overlap
// (lever arm r: moment_arm radius). Normal springs: the zone-boundary mode (neighbours in antiphase) has
// omega^2 = 4 kn / m. Tangential springs on the slip du_y - r (theta_k + theta_k+1) (and likewise in z): a Bloch wave
// of wavenumber q loads them through the vector (e^iq - 1, -r (1 + e^iq)) alone, so its one non-zero omega^2 is
// kt (|e^iq - 1|^2 / m + r^2 |1 + e^iq|^2 / I) = (kt / m)(7 + 3 cos q) with I = 2/5 m r^2: largest, 10 kt / m, for
// all spins turning together (q = 0) - stiffer than a pair's 7 kt / m.
State periodic_chain(int n, double radius, double overlap) {
  const double d = 2.0 * radius - overlap;
  std::vector<double> r(static_cast<std::size_t>(n), radius);
  std::vector<Vec3> x;
  for (int k = 0; k < n; ++k) x.emplace_back(d * (k + 0.5), 5.0 * radius, 5.0 * radius);
  Mat3 h = Mat3::Identity() * 10.0 * radius;
  h(0, 0) = n * d;
  return testing::make_state(h, r, x, 0.05);
}

double chain_omega(const Deck& deck, NetworkSprings springs, int* contacts = nullptr) {
  State state = periodic_chain(8, 0.5, 1e-3);
  const Model model = make_model(deck, state.particles.radius);
  rebuild_pairs(model, state);
  const NetworkTimeStep t = network_time_step_limit(model, state, springs);
  if (contacts) *contacts = t.contacts;
  EXPECT_NEAR(t.limit, 2.0 / t.omega_max, 1e-12 * t.limit);
  return t.omega_max;
}

TEST(NetworkTimeStep, PeriodicChainNormalModeIsTwiceThePairs) {
  const double kn = 1e4;
  Deck deck = model_deck(kn, kn, 1e-4);  // mass 1 kg
  deck.contact.moment_arm = MomentArm::Radius;
  int contacts = 0;
  // Without friction only the normal springs count: omega^2 = 4 kn / m (a pair's 2 kn / m).
  const double omega = chain_omega(deck, NetworkSprings{.tangential = false, .rolling = false}, &contacts);
  EXPECT_EQ(contacts, 8);
  EXPECT_NEAR(omega * omega, 4.0 * kn, 1e-8 * 4.0 * kn);
}

TEST(NetworkTimeStep, PeriodicChainTangentialModeTurnsEverySpin) {
  const double kn = 1e4, kt = 0.6 * kn;  // 10 kt > 4 kn: the spins' mode limits
  Deck deck = model_deck(kn, kt, 1e-4);
  deck.contact.moment_arm = MomentArm::Radius;
  const double omega = chain_omega(deck, NetworkSprings{});
  EXPECT_NEAR(omega * omega, 10.0 * kt, 1e-8 * 10.0 * kt);
}

// Hertz: the chain's normal springs are the law's tangent stiffness 2 E* a at the overlap, a = sqrt(R* overlap).
TEST(NetworkTimeStep, HertzChainUsesTheTangentStiffnessAtItsOverlap) {
  Deck deck = model_deck(0.0, 0.0, 1e-4);
  deck.contact.normal = NormalModel::Hertz;
  deck.contact.tangential = TangentialModel::Mindlin;
  deck.contact.youngs_modulus = 1e6;
  deck.contact.poisson_ratio = 0.25;
  deck.contact.reference_overlap = 1e-3;
  deck.contact.moment_arm = MomentArm::Radius;
  const double a = std::sqrt(0.25 * 1e-3);  // R* = r / 2 = 0.25
  const double kn = 2.0 * deck.contact.effective_modulus() * a;
  const double omega = chain_omega(deck, NetworkSprings{.tangential = false, .rolling = false});
  EXPECT_NEAR(omega * omega, 4.0 * kn, 1e-8 * 4.0 * kn);
  // With Mindlin's 8 G* a sticking: the spins' mode 10 kt / m where it exceeds 4 kn / m.
  const double kt = 8.0 * deck.contact.effective_shear_modulus() * a;
  const double sticking = chain_omega(deck, NetworkSprings{});
  EXPECT_NEAR(sticking * sticking, std::max(4.0 * kn, 10.0 * kt), 1e-8 * std::max(4.0 * kn, 10.0 * kt));
}

// Two spheres with rolling (sds) and twisting (marshall) springs: spins of equal size and opposite sign (no slip at
// the contact point, equal lever arms) are eigenvectors of A, across n with omega^2 = 2 k_roll R*^2 / I and along n
// with 2 k_tw / I, k_tw = kt a^2 / 2 (I = 2/5 m r^2).
TEST(NetworkTimeStep, RollingAndTwistingSpringsAddTheirModes) {
  const double kn = 1e4, kt = 1e3, radius = 0.5, overlap = 1e-3;
  Deck deck = model_deck(kn, kt, 1e-4);
  deck.contact.rolling = RollingModel::Sds;
  deck.contact.rolling_stiffness = 2e3;
  deck.contact.twisting = TwistingModel::Marshall;
  const Vec3 n = Vec3(1.0, 2.0, -0.5).normalized();
  State state = testing::make_state(Mat3::Identity() * 10.0, {radius, radius},
                                    {Vec3(5.0, 5.0, 5.0), Vec3(5.0, 5.0, 5.0) + n * (2 * radius - overlap)}, 0.05);
  const Model model = make_model(deck, state.particles.radius);
  rebuild_pairs(model, state);
  const Eigen::MatrixXd a(network_dynamic_matrix(model, state));
  const double inertia = 0.4 * 1.0 * radius * radius, r_eff = 0.5 * radius;
  const Vec3 across = n.cross(Vec3::UnitX()).normalized();
  const auto opposite_spins = [&](const Vec3& axis) {
    Eigen::VectorXd v = Eigen::VectorXd::Zero(12);
    v.segment<3>(3) = -axis, v.segment<3>(9) = axis;
    return v;
  };
  const Eigen::VectorXd roll = opposite_spins(across), twist = opposite_spins(n);
  const double roll_expected = 2.0 * deck.contact.rolling_stiffness * r_eff * r_eff / inertia;
  const double twist_expected = 2.0 * 0.5 * kt * r_eff * overlap / inertia;  // a^2 = R* overlap
  EXPECT_NEAR((a * roll - roll_expected * roll).norm(), 0.0, 1e-9 * roll_expected);
  EXPECT_NEAR((a * twist - twist_expected * twist).norm(), 0.0, 1e-9 * twist_expected);
  // Without rolling friction the rolling spring holds nothing; without sliding friction neither does the twist.
  const Eigen::MatrixXd free(
      network_dynamic_matrix(model, state, NetworkSprings{.tangential = false, .rolling = false}));
  EXPECT_NEAR((free * roll).norm() + (free * twist).norm(), 0.0, 1e-12 * roll_expected);
}

}  // namespace
}  // namespace celldem
