#include "contact/contact_forces.hpp"

#include <algorithm>
#include <vector>

namespace celldem {
namespace {

// Reductions are summed over fixed blocks of owner particles (their pairs in list order), then the blocks
// in order. Only touching pairs add to them, so the result depends neither on the number of threads nor on
// which non-touching pairs the neighbour list happens to hold (so a rebuild never changes the arithmetic).
constexpr std::size_t kBlock = 256;
// Pairs evaluated together by the SIMD loop before their in-order sums (small enough to stay in L1).
constexpr int kChunk = 64;

struct Partial {
  Mat3 stress_sum = Mat3::Zero();     // sum of force (x) branch [N m]
  Vec3 stiffness_sum = Vec3::Zero();  // sum of kn (n_k l_k)^2 [N m]
  std::int64_t touching = 0;
};

// What the in-order sums need from one chunk of the SIMD loop, one array per component.
struct ChunkTerms {
  alignas(64) double stress[9][kChunk];     // force_a * branch_b, row-major (a, b)
  alignas(64) double stiffness[3][kChunk];  // kn (n_k l_k)^2
  alignas(64) bool touching[kChunk];
  alignas(64) bool sliding[kChunk];
};

// Raw views of the arrays the loop reads and writes: SIMD lanes index them directly.
struct PairArrays {
  const double* __restrict scaled;     // (N, 3)
  const double* __restrict velocity;   // (N, 3)
  const double* __restrict spin;       // (N, 3)
  const double* __restrict radius;     // (N)
  const Index* __restrict owner;       // (P)
  const Index* __restrict neighbor;    // (P)
  const std::int32_t* __restrict image;  // (P, 3)
  double* __restrict tangential;       // (P, 3)
  double* __restrict force;            // (P, 3)
  double* __restrict torque_i;         // (P, 3)
  double* __restrict torque_j;         // (P, 3)
};

inline Real3 load3(const double* a, std::size_t k) { return {a[3 * k], a[3 * k + 1], a[3 * k + 2]}; }
inline void store3(double* a, std::size_t k, Real3 v) {
  a[3 * k] = v.x;
  a[3 * k + 1] = v.y;
  a[3 * k + 2] = v.z;
}
// m v with the sums left to right (as Eigen's product), skipping the zero terms of a diagonal m.
template <bool Diagonal>
inline Real3 apply(const Mat3& m, Real3 v) {
  if constexpr (Diagonal) return {m(0, 0) * v.x, m(1, 1) * v.y, m(2, 2) * v.z};
  else
    return {m(0, 0) * v.x + m(0, 1) * v.y + m(0, 2) * v.z, m(1, 0) * v.x + m(1, 1) * v.y + m(1, 2) * v.z,
            m(2, 0) * v.x + m(2, 1) * v.y + m(2, 2) * v.z};
}

// One pair through the law: its results go to the pair arrays, its reduction terms to the chunk.
template <Kinematics K, bool Diagonal>
[[gnu::always_inline]] inline void evaluate_pair(const ContactParams& law, const PairArrays& a, const Mat3& h,
                                                 const Mat3& L, double dt, Index q, ChunkTerms& terms, int k) {
  const Index i = a.owner[q], j = a.neighbor[q];
  const Real3 ds = load3(a.scaled, j) - load3(a.scaled, i) +
                   Real3{double(a.image[3 * q]), double(a.image[3 * q + 1]), double(a.image[3 * q + 2])};
  const Real3 branch = apply<Diagonal>(h, ds);
  Real3 dv = load3(a.velocity, j) - load3(a.velocity, i);
  if constexpr (K == Kinematics::Affine) dv = dv + apply<Diagonal>(L, branch);  // images move apart with the cell
  const PairContact c = contact_law(law, branch, a.radius[i], a.radius[j], dv, load3(a.spin, i), load3(a.spin, j),
                                    load3(a.tangential, q), dt);
  store3(a.force, q, c.force);
  store3(a.torque_i, q, c.torque_i);
  store3(a.torque_j, q, c.torque_j);
  store3(a.tangential, q, c.tangential);
  const double f[3] = {c.force.x, c.force.y, c.force.z}, l[3] = {branch.x, branch.y, branch.z};
  for (int r = 0; r < 3; ++r)
    for (int s = 0; s < 3; ++s) terms.stress[3 * r + s][k] = f[r] * l[s];
  const double nl[3] = {c.normal.x * branch.x, c.normal.y * branch.y, c.normal.z * branch.z};
  for (int r = 0; r < 3; ++r) terms.stiffness[r][k] = law.kn * (nl[r] * nl[r]);
  terms.touching[k] = c.touching;
  terms.sliding[k] = c.sliding;
}

// The SIMD loop over pairs q0 .. q0 + m - 1. Everything comes by value: the compiler then knows that no
// store in the loop can change the parameters, the cell or the array pointers.
template <Kinematics K, bool Diagonal>
[[gnu::target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")]]
void evaluate_chunk(ContactParams law, PairArrays a, Mat3 h, Mat3 L, double dt, Index q0, int m, ChunkTerms& terms) {
#pragma omp simd
  for (int k = 0; k < m; ++k) evaluate_pair<K, Diagonal>(law, a, h, L, dt, q0 + k, terms, k);
}

// Diagonal: the cell and the velocity gradient are diagonal (principal-axis loading, the common case); the
// products with h and L then skip their zero terms, which gives the same numbers bit for bit.
template <Kinematics K, bool Diagonal>
void pair_loop(const ContactParams& law, State& state, double dt) {
  Particles& p = state.particles;
  PairList& pl = state.pairs;
  const Mat3 h = state.cell.h;
  const Mat3 L = state.cell.velocity_gradient;
  const PairArrays a{p.scaled.data()->data(), p.velocity.data()->data(), p.spin.data()->data(), p.radius.data(),
                     pl.owner.data(), pl.neighbor.data(), pl.image.data()->data(), pl.tangential.data()->data(),
                     pl.force.data()->data(), pl.torque_i.data()->data(), pl.torque_j.data()->data()};
  const std::size_t n = p.size();
  const std::size_t blocks = (n + kBlock - 1) / kBlock;
  std::vector<Partial> partial(blocks);

#pragma omp parallel for schedule(static)
  for (std::size_t c = 0; c < blocks; ++c) {
    Partial acc;
    ChunkTerms terms;
    const std::size_t first_owner = c * kBlock, last_owner = std::min(n, (c + 1) * kBlock);
    // The owner's share of the net force and moment, summed here in pair order; the gather adds the pairs
    // where the particle is the neighbour.
    for (std::size_t i = first_owner; i < last_owner; ++i) {
      p.force[i].setZero();
      p.torque[i].setZero();
    }
    const Index begin = pl.first[first_owner], end = pl.first[last_owner];
    for (Index q0 = begin; q0 < end; q0 += kChunk) {
      const int m = std::min<Index>(kChunk, end - q0);
      evaluate_chunk<K, Diagonal>(law, a, h, L, dt, q0, m, terms);
      for (int k = 0; k < m; ++k) {
        const Index q = q0 + k;
        pl.flags[q] = static_cast<std::uint8_t>((terms.touching[k] ? kTouching : 0) | (terms.sliding[k] ? kSliding : 0));
        if (!terms.touching[k]) continue;
        const Index i = pl.owner[q];
        p.force[i] -= pl.force[q];
        p.torque[i] += pl.torque_i[q];
        for (int r = 0; r < 3; ++r)
          for (int s = 0; s < 3; ++s) acc.stress_sum(r, s) += terms.stress[3 * r + s][k];
        for (int r = 0; r < 3; ++r) acc.stiffness_sum[r] += terms.stiffness[r][k];
        ++acc.touching;
      }
    }
    partial[c] = acc;
  }

  Partial total;
  for (const Partial& part : partial) {
    total.stress_sum += part.stress_sum;
    total.stiffness_sum += part.stiffness_sum;
    total.touching += part.touching;
  }
  const double volume = state.cell.volume();
  state.stress = 0.5 * (total.stress_sum + total.stress_sum.transpose()) / volume;
  state.axis_stiffness = total.stiffness_sum / volume;
  state.touching = total.touching;
}

}  // namespace

void compute_contact_forces(const Model& model, double friction, State& state, bool advance_slip) {
  const double dt = advance_slip ? model.dt : 0.0;
  const ContactParams law{model.contact.kn, model.contact.kt, friction, model.contact.rotation,
                          model.contact.moment_arm};
  const auto off_diagonal = [](const Mat3& m) { return (m - Mat3(m.diagonal().asDiagonal())).cwiseAbs().maxCoeff(); };
  const bool diagonal = off_diagonal(state.cell.h) == 0.0 && off_diagonal(state.cell.velocity_gradient) == 0.0;
  if (model.kinematics == Kinematics::Affine) {
    if (diagonal) pair_loop<Kinematics::Affine, true>(law, state, dt);
    else pair_loop<Kinematics::Affine, false>(law, state, dt);
  } else {
    if (diagonal) pair_loop<Kinematics::Lammps, true>(law, state, dt);
    else pair_loop<Kinematics::Lammps, false>(law, state, dt);
  }
}

}  // namespace celldem
