#include "measure/network_stiffness.hpp"

#include <Eigen/SparseCore>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "contact/contact_law.hpp"
#include "measure/micro.hpp"

namespace celldem {
namespace {

// One contact of the network, as the linear law sees it in the state's geometry.
struct NetworkContact {
  Index i = 0, j = 0;
  Vec3 branch = Vec3::Zero();  // l [m], x_j - x_i across the pair's image
  Vec3 normal = Vec3::Zero();  // n, from i to j
  double distance = 0.0;       // |l| [m]
  double normal_force = 0.0;   // f_n [N], kn overlap
  Vec3 force = Vec3::Zero();   // [N] on j by i: f_n n + f_t
  double arm_i = 0.0, arm_j = 0.0;  // [m] lever arms from the centres to the contact point
};

// The law's local matrices of a contact over z = (u_i, u_j, theta_i, theta_j): dl = Jl z - eps l and
// du_c = Jc z - (affine part) eps l.
using Jacobian = Eigen::Matrix<double, 3, 12>;
using Local = Eigen::Matrix<double, 12, 12>;

Mat3 cross_matrix(const Vec3& n) {  // [n]x: [n]x t = n x t
  Mat3 m;
  m << 0.0, -n[2], n[1], n[2], 0.0, -n[0], -n[1], n[0], 0.0;
  return m;
}

struct ContactMatrices {
  Mat3 normal_stiffness;      // K_n = kn n n^T - (f_n / d)(I - n n^T) [N/m]
  Mat3 tangential_projector;  // kt (I - n n^T) [N/m] (zero without tangential springs)
  Jacobian branch_jacobian;   // Jl
  Jacobian contact_jacobian;  // Jc
};

// prestress: with the geometric term -(f_n / d)(I - n n^T) (normal springs only: the header says why).
ContactMatrices matrices_of(const NetworkContact& c, double kn, double kt, bool prestress) {
  const Mat3 nn = c.normal * c.normal.transpose();
  const Mat3 projector = Mat3::Identity() - nn;
  ContactMatrices m;
  m.normal_stiffness = kn * nn - (prestress ? c.normal_force / c.distance : 0.0) * projector;
  m.tangential_projector = kt * projector;
  m.branch_jacobian.setZero();
  m.branch_jacobian.block<3, 3>(0, 0) = -Mat3::Identity();
  m.branch_jacobian.block<3, 3>(0, 3) = Mat3::Identity();
  m.contact_jacobian = m.branch_jacobian;
  const Mat3 nx = cross_matrix(c.normal);
  m.contact_jacobian.block<3, 3>(0, 6) = c.arm_i * nx;
  m.contact_jacobian.block<3, 3>(0, 9) = c.arm_j * nx;
  return m;
}

void check_law(const ContactDef& contact) {
  const auto refuse = [](const std::string& key, std::string_view name) {
    throw std::invalid_argument("network_stiffness: contact." + key + " \"" + std::string(name) +
                                "\" is not supported (the linear law only: contact.normal linear, contact.tangential "
                                "linear_history, contact.rolling none, contact.twisting none)");
  };
  if (contact.normal != NormalModel::Linear) refuse("normal", name_of(contact.normal, kNormalModelNames));
  if (contact.tangential != TangentialModel::LinearHistory)
    refuse("tangential", name_of(contact.tangential, kTangentialModelNames));
  if (contact.rolling != RollingModel::None) refuse("rolling", name_of(contact.rolling, kRollingModelNames));
  if (contact.twisting != TwistingModel::None) refuse("twisting", name_of(contact.twisting, kTwistingModelNames));
}

// The pairs of the list that overlap in the state's geometry, in list order.
std::vector<NetworkContact> network_contacts(const Model& model, const State& state, bool tangential) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const double kt = tangential ? model.contact.kt : 0.0;
  std::vector<NetworkContact> contacts;
  for_each_pair(pl, [&](Index i, Index q) {
    const Index j = pl.neighbor[q];
    const Vec3 branch = pair_branch(state, i, q);
    const double distance = branch.norm();
    const double overlap = p.radius[i] + p.radius[j] - distance;
    if (!(overlap > 0.0)) return;
    NetworkContact c;
    c.i = i;
    c.j = j;
    c.branch = branch;
    c.distance = distance;
    c.normal = branch / distance;
    c.normal_force = model.contact.kn * overlap;
    const Vec3 spring = pl.tangential[q] - pl.tangential[q].dot(c.normal) * c.normal;  // in this tangent plane
    c.force = c.normal_force * c.normal - kt * spring;
    const LeverArms arms = lever_arms(model.contact.moment_arm, p.radius[i], p.radius[j], overlap);  // the law's
    c.arm_i = arms.i;
    c.arm_j = arms.j;
    contacts.push_back(c);
  });
  return contacts;
}

// The displacements of the particles in the solve: 3 translations and (with tangential springs) 3 spins each,
// -1 for what is not solved for (rattlers, the pinned particle's translation, spins without tangential springs).
struct Unknowns {
  std::vector<std::array<int, 6>> index;  // (N) per particle: u_x, u_y, u_z, theta_x, theta_y, theta_z
  int count = 0;
};

Unknowns number_unknowns(const std::vector<char>& rattler, bool tangential) {
  Unknowns u;
  u.index.assign(rattler.size(), {-1, -1, -1, -1, -1, -1});
  bool pinned = false;
  for (std::size_t p = 0; p < rattler.size(); ++p) {
    if (rattler[p]) continue;
    if (pinned)
      for (int a = 0; a < 3; ++a) u.index[p][a] = u.count++;
    pinned = true;  // the first particle kept: its translation fixes the rigid motion
    if (tangential)
      for (int a = 3; a < 6; ++a) u.index[p][a] = u.count++;
  }
  return u;
}

// The local unknowns z = (u_i, u_j, theta_i, theta_j) of a contact as indices of the solve (-1: held).
std::array<int, 12> local_unknowns(const Unknowns& u, const NetworkContact& c) {
  std::array<int, 12> z;
  for (int a = 0; a < 3; ++a) {
    z[a] = u.index[c.i][a];
    z[3 + a] = u.index[c.j][a];
    z[6 + a] = u.index[c.i][3 + a];
    z[9 + a] = u.index[c.j][3 + a];
  }
  return z;
}

// The stress change d sigma [Pa] for the strain eps and the displacements q (of the solve's unknowns; empty:
// every particle affine) over the contacts for which `use` holds, plus the volume term sigma tr(eps).
template <class Use>
Mat3 stress_change(const std::vector<NetworkContact>& contacts, const Unknowns& unknowns, const Eigen::VectorXd& q,
                   const Mat3& eps, const Mat3& stress, double kn, double kt, bool prestress, bool affine_tangential,
                   double volume, Use use) {
  Mat3 sum = Mat3::Zero();  // [N m] sum of df (x) l + f (x) dl
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    const NetworkContact& c = contacts[k];
    if (!use(k)) continue;
    const ContactMatrices m = matrices_of(c, kn, kt, prestress);
    Eigen::Matrix<double, 12, 1> z = Eigen::Matrix<double, 12, 1>::Zero();
    if (q.size() > 0) {
      const std::array<int, 12> index = local_unknowns(unknowns, c);
      for (int a = 0; a < 12; ++a)
        if (index[a] >= 0) z[a] = q[index[a]];
    }
    const Vec3 affine = eps * c.branch;
    const Vec3 dl = m.branch_jacobian * z - affine;
    const Vec3 du_c = m.contact_jacobian * z - (affine_tangential ? affine : Vec3::Zero());
    const Vec3 df = -(m.normal_stiffness * dl + m.tangential_projector * du_c);
    sum += df * c.branch.transpose() + c.force * dl.transpose();
  }
  return 0.5 * (sum + sum.transpose()) / volume + stress * eps.trace();
}

// Preconditioned conjugate gradients for K q = rhs, the six load cases at once (each column its own iteration),
// preconditioned by the inverses of K's diagonal blocks of each particle (its translation and spin, 3 or 6
// unknowns numbered together: first[b] to first[b + 1]). K is symmetric; a stable network makes it positive
// definite but for modes that no strain loads (a sphere's spin about the line of its only two contacts): the
// preconditioner leaves them out and the iteration never enters them. A direction of non-positive curvature,
// or no convergence (a mechanism the strain drives), means the network has no relaxed stiffness: an error.
// Row-major: Eigen shares a row-major sparse matrix's product with a dense one among the OpenMP threads.
using Hessian = Eigen::SparseMatrix<double, Eigen::RowMajor>;
using Block = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;

struct Relaxation {
  Eigen::MatrixXd displacement;  // (unknowns x 6)
  double residual = 0.0;         // largest |K q - rhs| / |rhs| of the columns
};

Relaxation relax(const Hessian& hessian, const Eigen::MatrixXd& rhs, const std::vector<Eigen::Index>& first,
                 int rattlers) {
  const Eigen::Index n = hessian.rows();
  const std::size_t blocks = first.size() - 1;
  std::vector<Block> block(blocks);
  std::vector<std::size_t> block_of(static_cast<std::size_t>(n));
  for (std::size_t b = 0; b < blocks; ++b) {
    block[b] = Block::Zero(first[b + 1] - first[b], first[b + 1] - first[b]);
    for (Eigen::Index k = first[b]; k < first[b + 1]; ++k) block_of[static_cast<std::size_t>(k)] = b;
  }
  for (Eigen::Index outer = 0; outer < hessian.outerSize(); ++outer)
    for (Hessian::InnerIterator it(hessian, outer); it; ++it) {
      const std::size_t b = block_of[static_cast<std::size_t>(it.row())];
      if (b == block_of[static_cast<std::size_t>(it.col())]) block[b](it.row() - first[b], it.col() - first[b]) = it.value();
    }
  for (Block& b : block) {  // the pseudo-inverse: directions without stiffness left out
    const Eigen::SelfAdjointEigenSolver<Block> eigen(b);
    const Eigen::VectorXd values = eigen.eigenvalues();
    Eigen::VectorXd inverse = Eigen::VectorXd::Zero(values.size());
    for (Eigen::Index k = 0; k < values.size(); ++k)
      if (values[k] > 1e-10 * values.cwiseAbs().maxCoeff()) inverse[k] = 1.0 / values[k];
    b = eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose();
  }
  const auto precondition = [&](const Eigen::MatrixXd& r) {
    Eigen::MatrixXd z(r.rows(), r.cols());
    for (std::size_t b = 0; b < blocks; ++b)
      z.middleRows(first[b], first[b + 1] - first[b]) = block[b] * r.middleRows(first[b], first[b + 1] - first[b]);
    return z;
  };
  constexpr double kTolerance = 1e-10;
  const Eigen::Index max_iterations = std::max<Eigen::Index>(1000, 4 * n);
  Relaxation out;
  out.displacement = Eigen::MatrixXd::Zero(n, rhs.cols());
  Eigen::MatrixXd r = rhs, z = precondition(r), p = z;
  Eigen::ArrayXd rz = (r.cwiseProduct(z)).colwise().sum().transpose().array();
  const Eigen::ArrayXd target = kTolerance * rhs.colwise().norm().transpose().array();
  Eigen::Array<bool, Eigen::Dynamic, 1> active = r.colwise().norm().transpose().array() > target;
  Eigen::Index iteration = 0;
  for (; active.any() && iteration < max_iterations; ++iteration) {
    const Eigen::MatrixXd kp = hessian * p;
    for (Eigen::Index c = 0; c < rhs.cols(); ++c) {
      if (!active[c]) continue;
      const double curvature = p.col(c).dot(kp.col(c));
      if (!(curvature > 0.0))
        throw std::runtime_error("network_stiffness: the contact network is not stable once its " +
                                 std::to_string(rattlers) + " rattlers are removed (a direction of non-positive "
                                 "stiffness: a buckling mode or a mechanism the strain drives)");
      const double alpha = rz[c] / curvature;
      out.displacement.col(c) += alpha * p.col(c);
      r.col(c) -= alpha * kp.col(c);
      if (r.col(c).norm() <= target[c]) active[c] = false;
    }
    z = precondition(r);
    for (Eigen::Index c = 0; c < rhs.cols(); ++c) {
      if (!active[c]) continue;
      const double rz_next = r.col(c).dot(z.col(c));
      p.col(c) = z.col(c) + (rz_next / rz[c]) * p.col(c);
      rz[c] = rz_next;
    }
  }
  const Eigen::MatrixXd residual = hessian * out.displacement - rhs;
  for (Eigen::Index c = 0; c < rhs.cols(); ++c)
    if (rhs.col(c).norm() > 0.0) out.residual = std::max(out.residual, residual.col(c).norm() / rhs.col(c).norm());
  if (active.any())
    throw std::runtime_error("network_stiffness: the relaxation did not converge in " + std::to_string(iteration) +
                             " iterations (relative residual " + std::to_string(out.residual) +
                             "): the contact network has a mechanism the strain drives, or is close to one");
  return out;
}

}  // namespace

Mat3 strain_of_voigt(const Voigt6& voigt) {
  Mat3 eps = Mat3::Zero();
  for (int k = 0; k < 6; ++k) {
    const auto [i, j] = kVoigtEntries[k];
    const double value = k < 3 ? voigt[k] : 0.5 * voigt[k];
    eps(i, j) = value;
    eps(j, i) = value;
  }
  return eps;
}

Voigt6 voigt_of_stress(const Mat3& stress) {
  const Mat3 sym = 0.5 * (stress + stress.transpose());
  Voigt6 v;
  for (int k = 0; k < 6; ++k) v[k] = sym(kVoigtEntries[k][0], kVoigtEntries[k][1]);
  return v;
}

Mat3 simple_shear_rotation(const Mat3& stress, const Vec3& shear) {
  Mat3 e = Mat3::Zero();
  for (int a = 0; a < 3; ++a) e(kShearAxisEntries[a][0], kShearAxisEntries[a][1]) = shear[a];
  const Mat3 omega = 0.5 * (e - e.transpose());
  return stress * omega - omega * stress;
}

int network_rattler_rule(bool tangential) { return tangential ? kFrictionalRattler : kFrictionlessRattler; }

NetworkStiffness network_stiffness(const Model& model, const State& state, bool tangential) {
  check_law(model.contact);
  const std::size_t n = state.particles.size();
  if (state.pairs.first.size() != n + 1 || state.pairs.tangential.size() != state.pairs.size())
    throw std::logic_error("network_stiffness: the pair list is not built (rebuild_pairs first)");
  const double kn = model.contact.kn, kt = tangential ? model.contact.kt : 0.0;
  const bool affine_tangential = model.kinematics == Kinematics::Affine;  // what the law's tangential slip sees
  const bool prestress = !tangential;
  const double volume = state.cell.volume();

  const std::vector<NetworkContact> contacts = network_contacts(model, state, tangential);
  std::vector<std::pair<Index, Index>> pairs;
  pairs.reserve(contacts.size());
  for (const NetworkContact& c : contacts) pairs.emplace_back(c.i, c.j);
  const std::vector<char> rattler = rattlers_of(n, pairs, network_rattler_rule(tangential));
  const auto kept = [&](std::size_t k) { return !rattler[contacts[k].i] && !rattler[contacts[k].j]; };
  const auto every = [](std::size_t) { return true; };

  Mat3 stress_sum = Mat3::Zero();
  for (const NetworkContact& c : contacts) stress_sum += c.force * c.branch.transpose();
  const Mat3 stress = 0.5 * (stress_sum + stress_sum.transpose()) / volume;

  NetworkStiffness out;
  out.contacts = static_cast<int>(contacts.size());
  for (char r : rattler) out.rattlers += r != 0;

  // The Hessian K (its lower triangle) and the load vectors B eps of the six unit strains.
  const Unknowns unknowns = number_unknowns(rattler, tangential);
  std::vector<Mat3> unit_strain(6);
  for (int k = 0; k < 6; ++k) unit_strain[k] = strain_of_voigt(Voigt6::Unit(k));
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(contacts.size() * (tangential ? 144 : 36));
  Eigen::MatrixXd load = Eigen::MatrixXd::Zero(unknowns.count, 6);
  for (std::size_t k = 0; k < contacts.size(); ++k) {
    if (!kept(k)) continue;
    const NetworkContact& c = contacts[k];
    const ContactMatrices m = matrices_of(c, kn, kt, prestress);
    const Local local = m.branch_jacobian.transpose() * m.normal_stiffness * m.branch_jacobian +
                        m.contact_jacobian.transpose() * m.tangential_projector * m.contact_jacobian;
    const std::array<int, 12> index = local_unknowns(unknowns, c);
    for (int a = 0; a < 12; ++a) {
      if (index[a] < 0) continue;
      for (int b = 0; b < 12; ++b)
        if (index[b] >= 0) triplets.emplace_back(index[a], index[b], local(a, b));
    }
    for (int s = 0; s < 6; ++s) {  // dE/dz at z = 0: -(Jl^T K_n + Jc^T kt P (affine part)) eps l
      const Vec3 affine = unit_strain[s] * c.branch;
      const Eigen::Matrix<double, 12, 1> b =
          -(m.branch_jacobian.transpose() * (m.normal_stiffness * affine) +
            m.contact_jacobian.transpose() * (m.tangential_projector * (affine_tangential ? affine : Vec3::Zero())));
      for (int a = 0; a < 12; ++a)
        if (index[a] >= 0) load(index[a], s) += b[a];
    }
  }

  Eigen::MatrixXd displacement = Eigen::MatrixXd::Zero(unknowns.count, 6);
  if (unknowns.count > 0) {
    Hessian hessian(unknowns.count, unknowns.count);
    hessian.setFromTriplets(triplets.begin(), triplets.end());
    triplets = {};
    std::vector<Eigen::Index> first;  // each particle's unknowns, numbered together
    for (const auto& index : unknowns.index) {
      const int begin = index[0] >= 0 ? index[0] : index[3];
      if (begin >= 0) first.push_back(begin);
    }
    first.push_back(unknowns.count);
    const Relaxation relaxation = relax(hessian, -load, first, out.rattlers);
    displacement = relaxation.displacement;
    out.solver_residual = relaxation.residual;
  }

  for (int s = 0; s < 6; ++s) {
    const Mat3& eps = unit_strain[s];
    out.affine.col(s) = voigt_of_stress(stress_change(contacts, unknowns, Eigen::VectorXd(), eps, stress, kn, kt,
                                                      prestress, affine_tangential, volume, every));
    const Eigen::VectorXd q = displacement.col(s);
    out.relaxed.col(s) = voigt_of_stress(stress_change(contacts, unknowns, q, eps, stress, kn, kt,
                                                       prestress, affine_tangential, volume, kept));
  }
  return out;
}

NetworkSprings network_springs(const Friction& friction) {
  return {.tangential = friction.sliding > 0.0, .rolling = friction.rolling > 0.0};
}

namespace {

// The law's tangent stiffnesses of one contact at its overlap (contact/contact_law.hpp), those `springs` keeps.
struct TangentSprings {
  double normal = 0.0;      // [N/m] d fn / d overlap
  double tangential = 0.0;  // [N/m] on the contact point's slip
  double rolling = 0.0;     // [N m/rad] k_roll R*^2 on the relative spin across n
  double twisting = 0.0;    // [N m/rad] 1/2 kt a^2 on the relative spin about n
};

TangentSprings tangent_springs(const ContactDef& law, NetworkSprings springs, double ri, double rj, double overlap) {
  const double r_eff = ri * rj / (ri + rj);
  const double a = std::sqrt(r_eff * std::max(overlap, 0.0));  // the contact radius
  TangentSprings k;
  k.normal = law.normal == NormalModel::Linear ? law.kn : 2.0 * law.effective_modulus() * a;
  const double kt = law.tangential == TangentialModel::LinearHistory ? law.kt : 8.0 * law.effective_shear_modulus() * a;
  if (springs.tangential) k.tangential = kt;
  if (springs.rolling && law.rolling == RollingModel::Sds) k.rolling = law.rolling_stiffness * r_eff * r_eff;
  if (springs.tangential && law.twisting == TwistingModel::Marshall) k.twisting = 0.5 * kt * a * a;
  return k;
}

// The 12 x 12 stiffness of one contact over z = (u_i, u_j, theta_i, theta_j): the normal and tangential springs of
// matrices_of, and the rotational springs on the relative spin dtheta = theta_j - theta_i (rolling: its part across
// n, |R* dtheta x n| = R* |P dtheta|; twisting: its part along n).
Local contact_stiffness(const NetworkContact& c, const TangentSprings& k) {
  const ContactMatrices m = matrices_of(c, k.normal, k.tangential, false);
  Local local = m.branch_jacobian.transpose() * m.normal_stiffness * m.branch_jacobian +
                m.contact_jacobian.transpose() * m.tangential_projector * m.contact_jacobian;
  if (k.rolling > 0.0 || k.twisting > 0.0) {
    const Mat3 nn = c.normal * c.normal.transpose();
    const Mat3 spring = k.rolling * (Mat3::Identity() - nn) + k.twisting * nn;
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)  // dtheta = -theta_i + theta_j
        local.block<3, 3>(6 + 3 * a, 6 + 3 * b) += (a == b ? 1.0 : -1.0) * spring;
  }
  return local;
}

}  // namespace

Eigen::SparseMatrix<double> network_dynamic_matrix(const Model& model, const State& state, NetworkSprings springs) {
  const std::size_t n = state.particles.size();
  if (state.pairs.first.size() != n + 1 || state.pairs.tangential.size() != state.pairs.size())
    throw std::logic_error("network_dynamic_matrix: the pair list is not built (rebuild_pairs first)");
  // M^-1/2 per unknown: 1/sqrt(m) for the translations, 1/sqrt(2/5 m r^2) for the spins.
  std::vector<double> weight(6 * n);
  for (std::size_t p = 0; p < n; ++p) {
    const double r = state.particles.radius[p], m = model.mass_of(r);
    for (int a = 0; a < 3; ++a) weight[6 * p + a] = 1.0 / std::sqrt(m), weight[6 * p + 3 + a] = 1.0 / std::sqrt(0.4 * m * r * r);
  }
  const std::vector<NetworkContact> contacts = network_contacts(model, state, true);
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(contacts.size() * 144);
  const std::vector<double>& radius = state.particles.radius;
  for (const NetworkContact& c : contacts) {
    const double overlap = radius[c.i] + radius[c.j] - c.distance;
    const Local local =
        contact_stiffness(c, tangent_springs(model.contact, springs, radius[c.i], radius[c.j], overlap));
    std::array<Index, 12> index;  // z = (u_i, u_j, theta_i, theta_j)
    for (int a = 0; a < 3; ++a)
      index[a] = 6 * c.i + a, index[3 + a] = 6 * c.j + a, index[6 + a] = 6 * c.i + 3 + a, index[9 + a] = 6 * c.j + 3 + a;
    for (int a = 0; a < 12; ++a)
      for (int b = 0; b < 12; ++b)
        if (local(a, b) != 0.0)
          triplets.emplace_back(index[a], index[b], weight[index[a]] * local(a, b) * weight[index[b]]);
  }
  Eigen::SparseMatrix<double> a(static_cast<Eigen::Index>(6 * n), static_cast<Eigen::Index>(6 * n));
  a.setFromTriplets(triplets.begin(), triplets.end());
  return a;
}

double largest_eigenvalue(const Eigen::SparseMatrix<double>& a, double tolerance, int* iterations, double* bound) {
  const Eigen::Index n = a.rows();
  if (n == 0) return 0.0;
  // A fixed start with a share of every unknown (no eigenvector of a symmetric packing is orthogonal to it by
  // accident): entries in [0.5, 1.5) from a Weyl sequence.
  Eigen::VectorXd v(n), previous = Eigen::VectorXd::Zero(n);
  for (Eigen::Index k = 0; k < n; ++k) v[k] = 0.5 + std::fmod(static_cast<double>(k) * 0.6180339887498949, 1.0);
  v.normalize();
  std::vector<double> alpha, beta;
  const int max_steps = static_cast<int>(std::min<Eigen::Index>(n, 2000));
  double theta = 0.0, residual = std::numeric_limits<double>::infinity();
  int k = 0;
  while (k < max_steps) {
    Eigen::VectorXd w = a * v;
    alpha.push_back(v.dot(w));
    w -= alpha.back() * v + (beta.empty() ? 0.0 : beta.back()) * previous;
    const double b = w.norm();
    ++k;
    // The tridiagonal T_k's largest Ritz value and its residual bound b |last entry of its eigenvector|
    // (every step at first, then every 10th: the eigenvectors of T_k cost k^3).
    if (k > 30 && k % 10 != 0 && k < max_steps && b > 1e-300) {
      beta.push_back(b);
      previous = v;
      v = w / b;
      continue;
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> ritz;
    const Eigen::VectorXd diagonal = Eigen::Map<const Eigen::VectorXd>(alpha.data(), k);
    const Eigen::VectorXd sub = beta.empty() ? Eigen::VectorXd() : Eigen::Map<const Eigen::VectorXd>(beta.data(), k - 1);
    ritz.computeFromTridiagonal(diagonal, sub, Eigen::ComputeEigenvectors);
    theta = ritz.eigenvalues()[k - 1];
    residual = b * std::abs(ritz.eigenvectors()(k - 1, k - 1));
    if (theta > 0.0 && residual <= tolerance * theta) break;
    if (!(b > 1e-300)) break;  // an invariant subspace: T_k's spectrum is A's on it
    beta.push_back(b);
    previous = v;
    v = w / b;
  }
  if (iterations) *iterations = k;
  if (bound) *bound = theta > 0.0 ? residual / theta : 0.0;
  return theta;
}

NetworkTimeStep network_time_step_limit(const Model& model, const State& state, NetworkSprings springs) {
  const auto start = std::chrono::steady_clock::now();
  NetworkTimeStep out;
  out.springs = springs;
  const Eigen::SparseMatrix<double> a = network_dynamic_matrix(model, state, springs);
  out.unknowns = static_cast<int>(a.rows());
  out.contacts = static_cast<int>(network_contacts(model, state, true).size());
  double gershgorin = 0.0;
  for (Eigen::Index col = 0; col < a.outerSize(); ++col) {  // symmetric: a column's sum is its row's
    double sum = 0.0;
    for (Eigen::SparseMatrix<double>::InnerIterator it(a, col); it; ++it) sum += std::abs(it.value());
    gershgorin = std::max(gershgorin, sum);
  }
  out.gershgorin_omega = std::sqrt(gershgorin);
  out.omega_max = out.contacts > 0 ? std::sqrt(largest_eigenvalue(a, kLanczosTolerance, &out.iterations, &out.residual_bound)) : 0.0;
  out.limit = out.omega_max > 0.0 ? 2.0 / out.omega_max : std::numeric_limits<double>::infinity();
  double r_min = std::numeric_limits<double>::infinity(), r_max = 0.0;
  for (const double r : state.particles.radius) r_min = std::min(r_min, r), r_max = std::max(r_max, r);
  const double m_min = state.particles.size() ? model.mass_of(r_min) : 0.0;
  // The pair formula's stiffnesses: the law's, at the reference overlap of the two largest spheres (core/plan
  // reference_stiffness) for the material laws.
  const ContactDef& law = model.contact;
  const double a_ref = std::sqrt(0.5 * r_max * law.reference_overlap);
  const double kn = law.normal == NormalModel::Linear ? law.kn : 2.0 * law.effective_modulus() * a_ref;
  const double kt = !springs.tangential                                ? 0.0
                    : law.tangential == TangentialModel::LinearHistory ? law.kt
                                                                       : 8.0 * law.effective_shear_modulus() * a_ref;
  out.pair_omega = m_min > 0.0 ? std::sqrt(std::max(2.0 * kn, 7.0 * kt) / m_min) : 0.0;
  out.pair_limit = out.pair_omega > 0.0 ? 2.0 / out.pair_omega : std::numeric_limits<double>::infinity();
  out.unit = std::sqrt(m_min / kn);
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace celldem
