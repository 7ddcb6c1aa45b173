#include "measure/micro.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "contact/contact_law.hpp"

namespace celldem {
namespace {

// The branch vector of pair q, owned by i.
Vec3 branch_of(const State& state, Index i, Index q) {
  const PairList& pl = state.pairs;
  const auto& img = pl.image[q];
  const Vec3 ds = state.particles.scaled[pl.neighbor[q]] - state.particles.scaled[i] +
                  Vec3(img[0], img[1], img[2]);
  return state.cell.h * ds;
}

}  // namespace

Fabric fabric_of(const std::vector<Vec3>& normals, const std::vector<double>& normal_forces) {
  Fabric f;
  const std::size_t nc = normals.size();
  f.contacts = static_cast<std::int64_t>(nc);
  if (nc == 0) return f;
  double mean = 0.0;
  for (double fn : normal_forces) mean += fn;
  mean /= static_cast<double>(nc);
  std::int64_t weak = 0;
  for (std::size_t c = 0; c < nc; ++c) {
    const Mat3 nn = normals[c] * normals[c].transpose();
    f.all += nn;
    if (normal_forces[c] > mean) {
      f.strong += nn;
      ++f.strong_contacts;
    } else {
      f.weak += nn;
      ++weak;
    }
  }
  f.all /= static_cast<double>(nc);
  if (f.strong_contacts) f.strong /= static_cast<double>(f.strong_contacts);
  if (weak) f.weak /= static_cast<double>(weak);
  return f;
}

Fabric contact_fabric(const Model&, const State& state) {
  const PairList& pl = state.pairs;
  std::vector<Vec3> normals;
  std::vector<double> forces;
  normals.reserve(state.touching);
  forces.reserve(state.touching);
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    const Vec3 n = branch_of(state, i, q).normalized();
    normals.push_back(n);
    forces.push_back(pl.force[q].dot(n));
  });
  return fabric_of(normals, forces);
}

Coordination coordination_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts, int min_contacts) {
  Coordination c;
  if (n == 0) return c;
  c.z = 2.0 * static_cast<double>(contacts.size()) / static_cast<double>(n);
  // Adjacency in CSR form; removing a rattler lowers its neighbours' degrees, which may make them
  // rattlers in turn: a work queue reaches the fixpoint in O(n + contacts).
  std::vector<int> degree(n, 0);
  std::vector<Index> first(n + 1, 0), adjacent(2 * contacts.size());
  for (const auto& [i, j] : contacts) ++first[i + 1], ++first[j + 1];
  for (std::size_t k = 0; k < n; ++k) first[k + 1] += first[k];
  {
    std::vector<Index> fill(first.begin(), first.end() - 1);
    for (const auto& [i, j] : contacts) adjacent[fill[i]++] = j, adjacent[fill[j]++] = i;
  }
  for (std::size_t k = 0; k < n; ++k) degree[k] = first[k + 1] - first[k];
  std::vector<char> rattler(n, 0);
  std::vector<Index> queue;
  for (std::size_t k = 0; k < n; ++k)
    if (degree[k] < min_contacts) rattler[k] = 1, queue.push_back(static_cast<Index>(k));
  while (!queue.empty()) {
    const Index k = queue.back();
    queue.pop_back();
    for (Index a = first[k]; a < first[k + 1]; ++a) {
      const Index m = adjacent[a];
      if (!rattler[m] && --degree[m] < min_contacts) rattler[m] = 1, queue.push_back(m);
    }
  }
  std::int64_t kept_contacts = 0, kept_particles = 0;
  for (const auto& [i, j] : contacts) kept_contacts += (!rattler[i] && !rattler[j]);
  for (std::size_t i = 0; i < n; ++i) kept_particles += !rattler[i];
  c.rattlers = static_cast<std::int64_t>(n) - kept_particles;
  c.z_mechanical = kept_particles ? 2.0 * static_cast<double>(kept_contacts) / static_cast<double>(kept_particles) : 0.0;
  return c;
}

Coordination coordination(const State& state, int min_contacts) {
  const PairList& pl = state.pairs;
  std::vector<std::pair<Index, Index>> contacts;
  contacts.reserve(state.touching);
  for_each_pair(pl, [&](Index i, Index q) {
    if (pl.flags[q] & kTouching) contacts.emplace_back(i, pl.neighbor[q]);
  });
  return coordination_of(state.particles.size(), contacts, min_contacts);
}

double sliding_fraction(const State& state) {
  const PairList& pl = state.pairs;
  std::int64_t touching = 0, sliding = 0;
  for (std::size_t q = 0; q < pl.size(); ++q) {
    touching += (pl.flags[q] & kTouching) != 0;
    sliding += (pl.flags[q] & kTouching) && (pl.flags[q] & kSliding);
  }
  return touching ? static_cast<double>(sliding) / static_cast<double>(touching) : 0.0;
}

double kinetic_energy(const Model& model, const State& state) {
  const Particles& p = state.particles;
  double e = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = p.radius[i];
    e += 0.5 * model.mass_of(r) * (p.velocity[i].squaredNorm() + 0.4 * r * r * p.spin[i].squaredNorm());
  }
  return e;
}

// Normal spring: fn^2 / (2 kn), or Hertz's 2/5 fn overlap; tangential spring: |ft|^2 / (2 kt) with kt the
// law's stiffness at this contact (mindlin: 8 G* a); rolling spring: k_roll |xi_r|^2 / 2; twist: k_tw theta^2 / 2.
double elastic_energy(const Model& model, const State& state) {
  const PairList& pl = state.pairs;
  const ContactDef& c = model.contact;
  const bool rotational = pl.rolling.size() == pl.size();
  double e = 0.0;
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    const Vec3 branch = branch_of(state, i, q);
    const Vec3 n = branch.normalized();
    const double fn = pl.force[q].dot(n);
    const double ft2 = (pl.force[q] - fn * n).squaredNorm();
    const Index j = pl.neighbor[q];
    const double ri = state.particles.radius[i], rj = state.particles.radius[j];
    const double overlap = ri + rj - branch.norm();
    const double a = std::sqrt(ri * rj / (ri + rj) * std::max(overlap, 0.0));
    const double kt = is_mindlin(c.tangential) ? tangential_stiffness_mindlin(c.effective_shear_modulus(), a) : c.kt;
    const double normal = c.normal == NormalModel::Hertz ? 0.4 * fn * overlap : 0.5 * fn * fn / c.kn;
    e += normal + (kt > 0.0 ? 0.5 * ft2 / kt : 0.0);
    if (rotational && c.rolling == RollingModel::Sds) e += 0.5 * c.rolling_stiffness * pl.rolling[q].squaredNorm();
    if (rotational && c.twisting == TwistingModel::Marshall) e += 0.25 * kt * a * a * pl.twist[q] * pl.twist[q];
  });
  return e;
}

double unbalanced_force_ratio(const Model& model, const State& state) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  double net = 0.0, normal = 0.0;
  std::int64_t touching = 0;
  for (std::size_t i = 0; i < p.size(); ++i) net += p.force[i].norm();
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    normal += pl.force[q].dot(branch_of(state, i, q).normalized());
    ++touching;
  });
  (void)model;
  if (touching == 0 || normal <= 0.0) return 0.0;
  return (net / static_cast<double>(p.size())) / (normal / static_cast<double>(touching));
}

double void_ratio(const Model& model, const State& state) {
  return state.cell.volume() / model.solid_volume - 1.0;
}

StressInvariants stress_invariants(const Mat3& s) {
  StressInvariants out;
  out.p = s.trace() / 3.0;
  const Mat3 dev = s - out.p * Mat3::Identity();
  out.q = std::sqrt(1.5 * dev.cwiseProduct(dev).sum());
  Eigen::SelfAdjointEigenSolver<Mat3> eig(s, Eigen::EigenvaluesOnly);
  const double s1 = eig.eigenvalues()[2], s3 = eig.eigenvalues()[0];
  out.sin_phi = (s1 + s3) != 0.0 ? (s1 - s3) / (s1 + s3) : 0.0;
  return out;
}

Vec3 principal_stresses(const Mat3& s) {
  Eigen::SelfAdjointEigenSolver<Mat3> eig(s, Eigen::EigenvaluesOnly);
  return Vec3(eig.eigenvalues()[2], eig.eigenvalues()[1], eig.eigenvalues()[0]);  // ascending -> descending
}

double b_value(double s11, double s22, double s33) {
  const double den = s11 - s33;
  return den != 0.0 ? (s22 - s33) / den : std::numeric_limits<double>::quiet_NaN();
}

std::vector<Mat3> particle_stresses(const State& state) {
  const Particles& p = state.particles;
  std::vector<Mat3> sigma(p.size(), Mat3::Zero());
  for_each_pair(state.pairs, [&](Index i, Index q) {
    const Index j = state.pairs.neighbor[q];
    const Mat3 fl = state.pairs.force[q] * branch_of(state, i, q).transpose();  // f (x) branch
    const Mat3 sym = 0.5 * (fl + fl.transpose()) / (p.radius[i] + p.radius[j]);
    sigma[i] += p.radius[i] * sym;
    sigma[j] += p.radius[j] * sym;
  });
  for (std::size_t i = 0; i < p.size(); ++i) sigma[i] /= 4.0 / 3.0 * M_PI * std::pow(p.radius[i], 3);
  return sigma;
}

std::vector<Vec3> net_contact_forces(const State& state) {
  std::vector<Vec3> net(state.particles.size(), Vec3::Zero());
  for_each_pair(state.pairs, [&](Index i, Index q) {
    net[i] -= state.pairs.force[q];
    net[state.pairs.neighbor[q]] += state.pairs.force[q];
  });
  return net;
}

Overlaps overlaps(const State& state, double deep) {
  Overlaps o;
  const std::vector<double>& r = state.particles.radius;
  for_each_pair(state.pairs, [&](Index i, Index q) {
    const Index j = state.pairs.neighbor[q];
    const double distance = branch_of(state, i, q).norm();
    const double overlap = r[i] + r[j] - distance;
    if (distance / (r[i] + r[j]) < o.closest) o.closest = distance / (r[i] + r[j]), o.closest_i = i, o.closest_j = j;
    if (overlap <= 0.0) return;
    ++o.count;
    if (overlap > deep * std::min(r[i], r[j])) ++o.deep;
    if (overlap / std::min(r[i], r[j]) > o.worst) o.worst = overlap / std::min(r[i], r[j]), o.worst_i = i, o.worst_j = j;
  });
  return o;
}

double overlap_dilation(const State& state, double max_overlap) {
  double factor = 1.0;
  const std::vector<double>& r = state.particles.radius;
  for_each_pair(state.pairs, [&](Index i, Index q) {
    const Index j = state.pairs.neighbor[q];
    const double reach = r[i] + r[j] - max_overlap * std::min(r[i], r[j]);
    const double distance = branch_of(state, i, q).norm();
    if (distance < reach) factor = std::max(factor, reach / distance);
  });
  return factor;
}

}  // namespace celldem
