#include "measure/micro.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "contact/contact_forces.hpp"
#include "contact/contact_law.hpp"

namespace celldem {

Vec3 pair_scaled_separation(const State& state, Index i, Index q) {
  const PairList& pl = state.pairs;
  const auto& img = pl.image[q];
  return state.particles.scaled[pl.neighbor[q]] - state.particles.scaled[i] + Vec3(img[0], img[1], img[2]);
}

Vec3 pair_branch(const State& state, Index i, Index q) { return state.cell.h * pair_scaled_separation(state, i, q); }

Fabric fabric_of(const std::vector<Vec3>& normals, const std::vector<double>& normal_forces) {
  Fabric f;
  const std::size_t nc = normals.size();
  f.contacts = static_cast<std::int64_t>(nc);
  if (nc == 0) return f;
  double mean = 0.0;
  for (double fn : normal_forces) mean += fn;
  mean /= static_cast<double>(nc);
  f.mean_normal_force = mean;
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

std::vector<char> rattlers_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts, int min_contacts) {
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
  return rattler;
}

Coordination coordination_of(std::size_t n, const std::vector<std::pair<Index, Index>>& contacts, int min_contacts) {
  Coordination c;
  if (n == 0) return c;
  c.z = 2.0 * static_cast<double>(contacts.size()) / static_cast<double>(n);
  const std::vector<char> rattler = rattlers_of(n, contacts, min_contacts);
  std::int64_t kept_contacts = 0, kept_particles = 0;
  for (const auto& [i, j] : contacts) kept_contacts += (!rattler[i] && !rattler[j]);
  for (std::size_t i = 0; i < n; ++i) kept_particles += !rattler[i];
  c.rattlers = static_cast<std::int64_t>(n) - kept_particles;
  c.z_mechanical = kept_particles ? 2.0 * static_cast<double>(kept_contacts) / static_cast<double>(kept_particles) : 0.0;
  return c;
}

ContactMeasures measure_contacts(const Model& model, const State& state) {
  const Particles& p = state.particles;
  const PairList& pl = state.pairs;
  const ContactDef& c = model.contact;
  const bool rotational = pl.rolling.size() == pl.size();
  ContactMeasures m;
  ContactStressSum stress(state.cell.h);
  std::vector<std::pair<Index, Index>> contacts;  // the touching pairs (i, j), in list order
  std::vector<Vec3> normals;                      // their unit normals, i to j
  std::vector<double> normal_forces;              // [N] their normal forces
  contacts.reserve(state.touching);
  normals.reserve(state.touching);
  normal_forces.reserve(state.touching);
  for_each_pair(pl, [&](Index i, Index q) {
    const Vec3 ds = pair_scaled_separation(state, i, q);
    stress.add(i, pl.force[q], ds);  // every listed pair (those apart hold zero force)
    if (!(pl.flags[q] & kTouching)) return;
    const Vec3 branch = state.cell.h * ds;
    const Index j = pl.neighbor[q];
    const Vec3 n = branch.normalized();
    const double fn = pl.force[q].dot(n);
    contacts.emplace_back(i, j);
    normals.push_back(n);
    normal_forces.push_back(fn);
    m.sliding += (pl.flags[q] & kSliding) != 0;
    // The springs' energy (ContactMeasures::elastic_energy).
    const double ft2 = (pl.force[q] - fn * n).squaredNorm();
    const double ri = p.radius[i], rj = p.radius[j];
    const double overlap = ri + rj - branch.norm();
    const double a = std::sqrt(ri * rj / (ri + rj) * std::max(overlap, 0.0));
    const double kt = is_mindlin(c.tangential) ? tangential_stiffness_mindlin(c.effective_shear_modulus(), a) : c.kt;
    const double normal = c.normal == NormalModel::Hertz ? 0.4 * fn * overlap : 0.5 * fn * fn / c.kn;
    m.elastic_energy += normal + (kt > 0.0 ? 0.5 * ft2 / kt : 0.0);
    if (rotational && c.rolling == RollingModel::Sds) m.elastic_energy += 0.5 * c.rolling_stiffness * pl.rolling[q].squaredNorm();
    if (rotational && c.twisting == TwistingModel::Marshall) m.elastic_energy += 0.25 * kt * a * a * pl.twist[q] * pl.twist[q];
  });
  m.stress = stress.stress(state.cell.volume());
  m.fabric = fabric_of(normals, normal_forces);
  m.coordination = coordination_of(p.size(), contacts, kFrictionalRattler);
  m.coordination_frictionless = coordination_of(p.size(), contacts, kFrictionlessRattler);
  const std::int64_t touching = m.fabric.contacts;
  m.sliding_fraction = touching ? static_cast<double>(m.sliding) / static_cast<double>(touching) : 0.0;

  double net = 0.0;  // [N] sum of |net contact force| over the particles
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double r = p.radius[i];
    m.kinetic_energy += 0.5 * model.mass_of(r) * (p.velocity[i].squaredNorm() + 0.4 * r * r * p.spin[i].squaredNorm());
    net += p.force[i].norm();
  }
  if (touching > 0 && m.fabric.mean_normal_force > 0.0)
    m.unbalanced_force = (net / static_cast<double>(p.size())) / m.fabric.mean_normal_force;
  return m;
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
    const Mat3 fl = state.pairs.force[q] * pair_branch(state, i, q).transpose();  // f (x) branch
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
    const double distance = pair_branch(state, i, q).norm();
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
    const double distance = pair_branch(state, i, q).norm();
    if (distance < reach) factor = std::max(factor, reach / distance);
  });
  return factor;
}

}  // namespace celldem
