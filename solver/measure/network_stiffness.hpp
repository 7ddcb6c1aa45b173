// The elastic stiffness of a packing assembled from its contact network: the tangent of the contact stress
// that celldem reports (measure/micro.hpp, sigma = (1/V) sum_c sym(f_c (x) l_c), compression positive) under a
// small homogeneous strain, with every particle following the affine field (affine) or relaxed to its new
// equilibrium (relaxed). No time stepping: one sparse linear solve. The linear contact law only.
//
// Conventions. Strain compression positive like the series' e1..e3 and g12..g23: a strain eps (symmetric)
// maps every branch l -> (I - eps) l and the cell h -> (I - eps) h. Voigt order (11, 22, 33, 12, 13, 23) for
// both stress and strain, engineering shear strains (gamma_ij = 2 eps_ij). celldem's shear axis g_ij is the
// simple shear h -> (I - E) h, E_ij = g_ij in the upper triangle: the symmetric strain gamma_ij = g_ij plus
// the spin omega = (E - E^T)/2, which turns the stress already carried by d sigma = sigma omega - omega sigma
// (of order sigma g, zero under an isotropic stress; simple_shear_rotation below), so a probe of g_ij
// measures D gamma plus that term.
//
// Derivation (docs/physics.md, "Stiffness of the contact network"; after Agnolin & Roux 2007, "Internal
// states of model isotropic granular packings. III. Elastic properties", PRE 76, 061304). Each contact c
// between i and j (branch l = x_j - x_i across its periodic image, |l| = d, normal n = l/d, overlap
// r_i + r_j - d > 0, normal force f_n = kn overlap, tangential force f_t = -kt xi from its stored spring)
// stores the quadratic energy of small displacements u (translations) and theta (spins, with tangential
// springs: 6 degrees of freedom per particle)
//   E_c = 1/2 dl^T K_n dl + 1/2 kt |P du_c|^2,   K_n = kn n n^T - (f_n / d)(I - n n^T),   P = I - n n^T,
//   dl   = u_j - u_i - eps l                     (the branch's change: fluctuation plus affine field),
//   du_c = dl + n x (a_i theta_i + a_j theta_j)  (the contact point's relative displacement, a_i, a_j the
//                                                 law's lever arms; without the affine part -eps l when the
//                                                 model's kinematics is lammps, as the law sees it),
// whose derivatives are the linear law's force and moments (the geometric term -(f_n/d)(I - nn): the normal
// force turning with the normal). Summed: E = 1/2 q^T K q + q^T B eps + (terms in eps alone), q the
// displacements. The relaxed displacements minimise E at fixed eps: K q = -B eps (K assembled sparse, rattlers
// dropped, one particle's translation pinned against the rigid motion; block-preconditioned conjugate
// gradients). The stress change is then the linearised definition of the stress itself,
//   d sigma = (1/V) sum_c sym(df_c (x) l_c + f_c (x) dl_c) + sigma tr(eps)   (V shrinks by tr eps),
// df_c = -(K_n dl + kt P du_c) the change of the force on j: D_affine from q = 0, D_relaxed from the relaxed q,
// column by column. In equilibrium D_relaxed = D_affine - (1/V) B^T K^-1 B: relaxation only softens, and
// D_relaxed - D_affine is symmetric. D_affine itself is symmetric but for sigma_ij delta_kl (the volume term),
// whose antisymmetric part sigma (x) 1 - 1 (x) sigma vanishes only under an isotropic stress; the residual
// forces of a packing not exactly in equilibrium add terms of order (net force) x (displacement).
//
// With normal springs only (tangential = false: a frictionless packing; tangential forces and springs left
// out) this is the whole linearisation of the law, checked against celldem's own quasi-static strain probes.
// With tangential springs the geometric term is left out (K_n = kn n n^T): it is of relative order f_n/(kn d)
// = overlap/d against kn and kt, the same order as the tangential force's own geometric terms (f_t turning with
// the normal, the lever arms changing with the overlap), which no energy gives (K would be unsymmetric); kept
// alone, it makes the rolling modes of chains of two-contact spheres, which no spring resists, unstable, so that
// a settled frictional packing of 8000 spheres has no minimum. Without it K is positive semidefinite, its zero
// modes (a free spin) are loaded by no strain, and the solve always exists.
#pragma once
#include <array>

#include <Eigen/Dense>
#include <Eigen/SparseCore>

#include "core/deck.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

using Voigt6 = Vec6;
using Stiffness6 = Eigen::Matrix<double, 6, 6>;

// The tensor entries (i, j) of the Voigt components, in order 11, 22, 33, 12, 13, 23.
inline constexpr std::array<std::array<int, 2>, 6> kVoigtEntries = {{{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}}};

// The symmetric strain tensor of a Voigt strain vector (engineering shear: eps_ij = eps_ji = gamma_ij / 2).
Mat3 strain_of_voigt(const Voigt6& voigt);
// The Voigt vector (s11, s22, s33, s12, s13, s23) of a stress tensor's symmetric part.
Voigt6 voigt_of_stress(const Mat3& stress);
// The stress change [Pa] that celldem's simple shear g_ij (h -> (I - E) h, E_ij = g_ij in the upper triangle)
// adds to D gamma by turning the stress already carried: sigma omega - omega sigma, omega = (E - E^T)/2.
// shear: (g12, g13, g23).
Mat3 simple_shear_rotation(const Mat3& stress, const Vec3& shear);

struct NetworkStiffness {
  Stiffness6 affine = Stiffness6::Zero();   // [Pa] every particle follows the affine field (the Voigt bound)
  Stiffness6 relaxed = Stiffness6::Zero();  // [Pa] the particles (and spins, with tangential springs) relaxed
  int contacts = 0;   // contacts with positive overlap in the state
  int rattlers = 0;   // particles left out of the solve (too few contacts, iteratively: network_rattler_rule)
  double solver_residual = 0.0;  // largest |K q + B eps| / |B eps| of the six solves
};

// The minimum number of contacts of a particle kept in the solve: 2 with tangential springs (a sphere with
// friction is held by two), d + 1 = 4 with normal springs only (fewer leave a direction whose only stiffness
// is the prestress's negative -f_n/d). Rattlers are removed iteratively (measure/micro.hpp's rules).
int network_rattler_rule(bool tangential);

// The stiffnesses of the state's contact network: the pairs of its list that overlap in the state's geometry,
// the normal force from the overlap and, with `tangential`, the tangential force and sticking spring kt of the
// stored spring (state.pairs.tangential). Throws std::invalid_argument naming the law unless the contact law
// is the linear one (normal linear, tangential linear_history, no rolling or twisting resistance), and
// std::runtime_error when the relaxed network is not stable once the rattlers are removed (a direction of
// non-positive stiffness, or no convergence: a buckling mode, or a mechanism the strain drives, as in a
// frictionless packing below isostaticity). The rattlers' contacts count in D_affine (every particle follows
// the strain) and not in D_relaxed (a rattler, free to move, carries nothing). The state's pair list must be
// built (rebuild_pairs); its forces need not be evaluated.
NetworkStiffness network_stiffness(const Model& model, const State& state, bool tangential);

// Which springs of the law the network has: the tangential (and twisting) springs only where the stage's friction can
// hold them (mu = 0 caps them at 0, as in the preparation), the rolling springs only where mu_roll > 0.
struct NetworkSprings {
  bool tangential = true;
  bool rolling = true;
};
NetworkSprings network_springs(const Friction& friction);

// The stability limit of the time step from the whole network's spectrum (docs/physics.md, "The time step from
// the contact network"). Every contact that overlaps in the state is a sticking contact with the law's tangent
// stiffnesses at its overlap: K_n = kn n n^T (no prestress term; kn = 2 E* a for hertz), kt (8 G* a for the
// mindlin laws) on the contact point's slip with the law's lever arms, as in network_stiffness with tangential
// springs, k_roll R*^2 on the relative spin across n (rolling sds) and 1/2 kt a^2 on the relative spin about n
// (twisting marshall), each as `springs` keeps it; every particle has its 3 translations (mass m) and 3 spins
// (moment of inertia 2/5 m r^2), none pinned, rattlers kept. omega_max^2 is the largest eigenvalue of the
// mass-weighted stiffness A = M^-1/2 K M^-1/2 (network_dynamic_matrix), found by Lanczos iteration (no
// reorthogonalisation: the extreme Ritz value converges first) until the residual bound beta_k |s_k| of its Ritz
// pair is below kLanczosTolerance of it (an eigenvalue of A lies within that bound); the undamped leapfrog is
// stable for dt < 2 / omega_max. For comparison, the pair formula of core/plan (critical_time_steps, whose t_c is
// sqrt(2) / omega): the largest mode of two of the state's smallest spheres in contact, normal omega^2 = 2 kn / m,
// tangential-rotational 7 kt / m (with tangential springs), kn and kt the law's at contact.reference_overlap for
// the material laws (core/plan reference_stiffness), here as its own leapfrog limit 2 / omega_pair (= sqrt(2)
// t_c); and Gershgorin's bound max_i sum_j |A_ij| >= omega_max^2, cheap and never below it. The pair list must
// be built.
inline constexpr double kLanczosTolerance = 1e-8;
struct NetworkTimeStep {
  double omega_max = 0.0;         // [rad/s] the network's largest angular frequency (0: no contact)
  double limit = 0.0;             // [s] 2 / omega_max (+inf without contacts)
  double pair_omega = 0.0;        // [rad/s] the pair formula's largest mode, two smallest spheres
  double pair_limit = 0.0;        // [s] 2 / pair_omega
  double gershgorin_omega = 0.0;  // [rad/s] sqrt of Gershgorin's bound: never below omega_max
  double unit = 0.0;              // [s] sqrt(m_min / kn), m_min the smallest sphere's mass (kn: the reference one)
  int iterations = 0;             // Lanczos steps, each one product with A
  double residual_bound = 0.0;    // the Ritz value's residual bound over it (relative, on omega_max^2)
  double seconds = 0.0;           // wall time of assembly and iteration
  int contacts = 0;
  int unknowns = 0;               // 6 per particle
  NetworkSprings springs;         // the springs it counted
};
NetworkTimeStep network_time_step_limit(const Model& model, const State& state, NetworkSprings springs = {});
// A = M^-1/2 K M^-1/2 of network_time_step_limit [1/s^2], 6 unknowns per particle (u_x, u_y, u_z, theta_x,
// theta_y, theta_z of particle p at 6p..6p+5): the matrix whose largest eigenvalue is omega_max^2.
Eigen::SparseMatrix<double> network_dynamic_matrix(const Model& model, const State& state, NetworkSprings springs = {});
// The largest eigenvalue of a symmetric positive semidefinite matrix by Lanczos iteration from a fixed start,
// to the residual bound `tolerance` (relative); iterations and the bound reached through the pointers.
double largest_eigenvalue(const Eigen::SparseMatrix<double>& a, double tolerance, int* iterations = nullptr,
                          double* bound = nullptr);

}  // namespace celldem
