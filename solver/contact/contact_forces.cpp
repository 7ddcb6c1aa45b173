#include "contact/contact_forces.hpp"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/check.hpp"
#include "core/isa_clones.hpp"
#include "core/parallel.hpp"

#if defined(__x86_64__)
#include <immintrin.h>
#endif

namespace celldem {
namespace {

// Pairs evaluated together by the SIMD loop before their in-order sums (small enough to stay in L1).
constexpr int kChunk = 64;

// The doubles of an array of 3-vectors (null when it is empty: no pairs cross, say).
inline double* doubles(std::vector<Vec3>& v) { return v.empty() ? nullptr : v.front().data(); }

// A chunk of pairs in SIMD form: the particle data of both ends gathered component-major, one lane per
// pair, so that the law runs on unit-stride loads; the pair arrays themselves are read and written in place.
struct ChunkIn {
  alignas(64) Index owner[kChunk + 8];  // i of each pair (chunk_owners; it writes eight at a time)
  alignas(64) double ds[3][kChunk];  // s_j - s_i + image (scaled branch)
  alignas(64) double dv[3][kChunk];  // v_j - v_i (fluctuating velocities)
  alignas(64) double wi[3][kChunk];
  alignas(64) double wj[3][kChunk];
  alignas(64) double ri[kChunk];
  alignas(64) double rj[kChunk];
};
// What the in-order sums after the SIMD loop need besides the pair arrays.
struct ChunkOut {
  alignas(64) double normal[3][kChunk];     // force_k * branch_k
  alignas(64) double stiffness[3][kChunk];  // kn (n_k l_k)^2
  alignas(64) double shear[3][kChunk];      // (force_i branch_j + force_j branch_i) / 2, ij = 12, 13, 23
  alignas(64) double shear_stiffness[3][kChunk];  // kn (n_i l_j)^2, ij = 12, 13, 23
  alignas(64) std::int64_t flags[kChunk];   // PairFlag bits
  // The energy budget's (Energy): (force_i branch_j - force_j branch_i) / 2, ij = 12, 13, 23, and each pair's
  // dissipation (PairContact::slip_work, rotational_slip_work, dashpot_work).
  alignas(64) double spin[3][kChunk];
  alignas(64) double dissipation[3][kChunk];
};

// m v with the sums left to right (as Eigen's product), skipping the zero terms of a diagonal m.
template <bool Diagonal>
inline Real3 apply(const Mat3& m, Real3 v) {
  if constexpr (Diagonal) return {m(0, 0) * v.x, m(1, 1) * v.y, m(2, 2) * v.z};
  else
    return {m(0, 0) * v.x + m(0, 1) * v.y + m(0, 2) * v.z, m(1, 0) * v.x + m(1, 1) * v.y + m(1, 2) * v.z,
            m(2, 0) * v.x + m(2, 1) * v.y + m(2, 2) * v.z};
}

// The owners of pairs q0 .. q0+m-1, from the list's offsets (it stores no owner per pair). owner: an owner
// whose row reaches the chunk (first[owner] <= q0 <= first[owner + 1]) on entry, the same for the next chunk
// on return. The rows are written eight entries at a time, in owner order: a row's last eight run over into
// the rows after it, which overwrite them (a row without pairs writes eight that its successor overwrites),
// so a row of up to eight pairs costs one store and no branch that depends on its length.
void chunk_owners(const Index* __restrict first, Index q0, int m, Index& owner, Index* __restrict owners) {
  CELLDEM_ASSERT(first[owner] <= q0 && q0 <= first[owner + 1], "the chunk's first pair lies in its owner's row");
  Index i = owner, start = 0;
  for (;;) {
    const Index end = first[i + 1] - q0;
    Index k = start;
    do {
      for (int t = 0; t < 8; ++t) owners[k + t] = i;
      k += 8;
    } while (k < end && k < m);
    if (end >= m) break;
    start = end;
    ++i;
  }
  owner = i;
}

// Lane k of the chunk: the particle data of pair q's ends (owner i).
inline void gather_chunk_lane(const Particles& p, const PairList& pl, Index q, Index i, int k, ChunkIn& c) {
  const Index j = pl.neighbor[q];
  for (int d = 0; d < 3; ++d) {
    c.ds[d][k] = p.scaled[j][d] - p.scaled[i][d] + pl.image[q][d];
    c.dv[d][k] = p.velocity[j][d] - p.velocity[i][d];
    c.wi[d][k] = p.spin[i][d];
    c.wj[d][k] = p.spin[j][d];
  }
  c.ri[k] = p.radius[i];
  c.rj[k] = p.radius[j];
}

void gather_chunk(const Particles& p, const PairList& pl, Index q0, int m, ChunkIn& c) {
  for (int k = 0; k < m; ++k) gather_chunk_lane(p, pl, q0 + k, c.owner[k], k, c);
}

#if defined(__x86_64__)
// gather_chunk four pairs at a time in AVX2, in about 40 instructions a pair instead of 65: each end's three
// components come in one masked load (the fourth lane is neither read nor used), the differences are taken
// on whole vectors, and four pairs' vectors are transposed into the chunk's component rows. The same
// operations on the same numbers, so the same bits.
[[gnu::target("avx2")]] inline __m256d load_xyz(const double* v, __m256i xyz) { return _mm256_maskload_pd(v, xyz); }

// Rows x, y, z of four 3-vectors (their fourth lanes ignored), stored at row[d][k .. k+3].
[[gnu::target("avx2")]] inline void store_transposed(const __m256d (&v)[4], double (&row)[3][kChunk], int k) {
  const __m256d xz01 = _mm256_unpacklo_pd(v[0], v[1]), y_01 = _mm256_unpackhi_pd(v[0], v[1]);
  const __m256d xz23 = _mm256_unpacklo_pd(v[2], v[3]), y_23 = _mm256_unpackhi_pd(v[2], v[3]);
  _mm256_store_pd(row[0] + k, _mm256_permute2f128_pd(xz01, xz23, 0x20));
  _mm256_store_pd(row[1] + k, _mm256_permute2f128_pd(y_01, y_23, 0x20));
  _mm256_store_pd(row[2] + k, _mm256_permute2f128_pd(xz01, xz23, 0x31));
}

[[gnu::target("avx2")]] void gather_chunk_avx2(const Particles& p, const PairList& pl, Index q0, int m, ChunkIn& c) {
  const __m256i xyz = _mm256_setr_epi64x(-1, -1, -1, 0);
  // (Local pointers: the chunk's stores could otherwise alias the vectors' own pointers, reloaded each pair.)
  const double* const scaled = p.scaled.front().data();
  const double* const velocity = p.velocity.front().data();
  const double* const spin = p.spin.front().data();
  const double* const radius = p.radius.data();
  const Index* const neighbor = pl.neighbor.data() + q0;
  const PairImage* const images = pl.image.data() + q0;
  const int whole = m & ~3;
  for (int k = 0; k < whole; k += 4) {
    __m256d ds[4], dv[4], wi[4], wj[4];
#pragma GCC unroll 4
    for (int u = 0; u < 4; ++u) {
      const std::size_t i = c.owner[k + u], j = neighbor[k + u];
      // The image's three int16 as int32 lanes (two loads, no store: a store and a wider reload would stall).
      const PairImage& n = images[k + u];
      const __m128i n16 = _mm_insert_epi16(_mm_loadu_si32(n.data()), n[2], 2);
      const __m256d image = _mm256_cvtepi32_pd(_mm_cvtepi16_epi32(n16));
      ds[u] = _mm256_add_pd(_mm256_sub_pd(load_xyz(scaled + 3 * j, xyz), load_xyz(scaled + 3 * i, xyz)), image);
      dv[u] = _mm256_sub_pd(load_xyz(velocity + 3 * j, xyz), load_xyz(velocity + 3 * i, xyz));
      wi[u] = load_xyz(spin + 3 * i, xyz);
      wj[u] = load_xyz(spin + 3 * j, xyz);
      c.ri[k + u] = radius[i];
      c.rj[k + u] = radius[j];
    }
    store_transposed(ds, c.ds, k);
    store_transposed(dv, c.dv, k);
    store_transposed(wi, c.wi, k);
    store_transposed(wj, c.wj, k);
  }
  for (int k = whole; k < m; ++k) gather_chunk_lane(p, pl, q0 + k, c.owner[k], k, c);
}

const bool cpu_has_avx2 = __builtin_cpu_supports("avx2");
#else
const bool cpu_has_avx2 = false;
#endif

std::atomic<bool> portable_gather{false};

// The law for every pair of the chunk, one SIMD lane each. tangential and force are the chunk's slices of
// the pair arrays (three doubles per pair). Everything else comes by value, so that the compiler
// knows no store in the loop changes the parameters or the cell.
template <class Law, Kinematics K, bool Diagonal, bool Shear, bool Energy>
CELLDEM_ISA_CLONES void evaluate_chunk(ContactParams law, Mat3 h, Mat3 L, double dt, int m, const ChunkIn& __restrict c,
                                       double* __restrict tangential, double* __restrict rolling,
                                       double* __restrict twist, double* __restrict radius, double* __restrict force,
                                       double* __restrict torque_i, double* __restrict torque_j,
                                       ChunkOut& __restrict o) {
  for (int k = 0; k < m; ++k) {
    const Real3 branch = apply<Diagonal>(h, {c.ds[0][k], c.ds[1][k], c.ds[2][k]});
    Real3 dv{c.dv[0][k], c.dv[1][k], c.dv[2][k]};
    if constexpr (K == Kinematics::Affine) dv = dv + apply<Diagonal>(L, branch);  // images move apart with the cell
    ContactHistory before;
    before.tangential = {tangential[3 * k], tangential[3 * k + 1], tangential[3 * k + 2]};
    if constexpr (Law::rotational) {
      before.rolling = {rolling[3 * k], rolling[3 * k + 1], rolling[3 * k + 2]};
      before.twist = twist[k];
    }
    if constexpr (Law::radius_history) before.contact_radius = radius[k];
    const PairContact r = contact_law<Law>(law, branch, c.ri[k], c.rj[k], dv, {c.wi[0][k], c.wi[1][k], c.wi[2][k]},
                                           {c.wj[0][k], c.wj[1][k], c.wj[2][k]}, before, dt);
    const Real3& xi = r.history.tangential;
    tangential[3 * k] = xi.x, tangential[3 * k + 1] = xi.y, tangential[3 * k + 2] = xi.z;
    if constexpr (Law::rotational) {
      const Real3& xr = r.history.rolling;
      rolling[3 * k] = xr.x, rolling[3 * k + 1] = xr.y, rolling[3 * k + 2] = xr.z;
      twist[k] = r.history.twist;
    }
    if constexpr (Law::radius_history) radius[k] = r.history.contact_radius;
    force[3 * k] = r.force.x, force[3 * k + 1] = r.force.y, force[3 * k + 2] = r.force.z;
    torque_i[3 * k] = r.torque_i.x, torque_i[3 * k + 1] = r.torque_i.y, torque_i[3 * k + 2] = r.torque_i.z;
    torque_j[3 * k] = r.torque_j.x, torque_j[3 * k + 1] = r.torque_j.y, torque_j[3 * k + 2] = r.torque_j.z;
    o.normal[0][k] = r.force.x * branch.x, o.normal[1][k] = r.force.y * branch.y, o.normal[2][k] = r.force.z * branch.z;
    const Real3 nl{r.normal.x * branch.x, r.normal.y * branch.y, r.normal.z * branch.z};
    const double kn = r.normal_stiffness;
    o.stiffness[0][k] = kn * (nl.x * nl.x), o.stiffness[1][k] = kn * (nl.y * nl.y), o.stiffness[2][k] = kn * (nl.z * nl.z);
    if constexpr (Shear) {
      o.shear[0][k] = 0.5 * (r.force.x * branch.y + r.force.y * branch.x);
      o.shear[1][k] = 0.5 * (r.force.x * branch.z + r.force.z * branch.x);
      o.shear[2][k] = 0.5 * (r.force.y * branch.z + r.force.z * branch.y);
      const Real3 nt{r.normal.x * branch.y, r.normal.x * branch.z, r.normal.y * branch.z};  // n_i l_j, ij = 12, 13, 23
      o.shear_stiffness[0][k] = kn * (nt.x * nt.x), o.shear_stiffness[1][k] = kn * (nt.y * nt.y);
      o.shear_stiffness[2][k] = kn * (nt.z * nt.z);
    }
    if constexpr (Energy) {
      o.spin[0][k] = 0.5 * (r.force.x * branch.y - r.force.y * branch.x);
      o.spin[1][k] = 0.5 * (r.force.x * branch.z - r.force.z * branch.x);
      o.spin[2][k] = 0.5 * (r.force.y * branch.z - r.force.z * branch.y);
      o.dissipation[0][k] = r.slip_work, o.dissipation[1][k] = r.rotational_slip_work;
      o.dissipation[2][k] = r.dashpot_work;
    }
    o.flags[k] = (r.touching ? kTouching : 0) | (r.sliding ? kSliding : 0);
  }
}

// What sum_chunk carries from chunk to chunk within a reduction block: the block's sums so far.
struct RunningSums {
  double normal[3] = {};     // sum of force_k branch_k [N m]
  double stiffness[3] = {};  // sum of kn (n_k l_k)^2 [N m]
  double shear[3] = {};      // sum of (force_i branch_j + force_j branch_i) / 2, ij = 12, 13, 23 [N m]
  double shear_stiffness[3] = {};  // sum of kn (n_i l_j)^2 [N m]
  double spin[3] = {};             // sum of (force_i branch_j - force_j branch_i) / 2 [N m] (Energy)
  double dissipation[3] = {};      // [J] slip, rotational slip, dashpot (Energy)
  std::int64_t touching = 0;
};

// Stores the chunk's flags and adds its pairs, in pair order, to the reduction block's sums. Pairs apart add
// zeros, so they change no sum: nothing depends on whether a pair touches.
template <bool Shear, bool Energy>
void sum_chunk(const ChunkOut& c, Index q0, int m, std::uint8_t* __restrict flags, RunningSums& block) {
  RunningSums s = block;
  for (int k = 0; k < m; ++k) {
    for (int a = 0; a < 3; ++a) s.normal[a] += c.normal[a][k];
    for (int a = 0; a < 3; ++a) s.stiffness[a] += c.stiffness[a][k];
    if constexpr (Shear) {
      for (int a = 0; a < 3; ++a) s.shear[a] += c.shear[a][k];
      for (int a = 0; a < 3; ++a) s.shear_stiffness[a] += c.shear_stiffness[a][k];
    }
    if constexpr (Energy) {
      for (int a = 0; a < 3; ++a) s.spin[a] += c.spin[a][k];
      for (int a = 0; a < 3; ++a) s.dissipation[a] += c.dissipation[a][k];
    }
    s.touching += c.flags[k] & kTouching;
  }
  for (int k = 0; k < m; ++k) flags[q0 + k] = static_cast<std::uint8_t>(c.flags[k]);
  block = s;
}

// The calling thread's share of the pairs: force blocks with about equal numbers of pairs (thread_blocks),
// each in reduction blocks (kReductionBlock owners), each in chunks; neither kind of block depends on
// which thread takes it. Diagonal: the cell and the velocity gradient are diagonal
// (principal-axis loading, the common case); the products with h and L then skip their zero terms, which
// gives the same numbers bit for bit. Shear: the shear stresses and stiffnesses are summed too (a shear servo
// reads them; 7 % of the linear law's pair loop, so only loadings that need them pay for them).
template <class Law, Kinematics K, bool Diagonal, bool Shear, bool Energy>
void evaluate_share(const ContactParams& law, State& state, double dt, std::vector<ReductionSums>& reduction_sums,
                    const std::vector<std::size_t>& blocks, const BlocksDone& blocks_done) {
  Particles& p = state.particles;
  PairList& pl = state.pairs;
  const Mat3 h = state.cell.h;
  const Mat3 L = state.cell.velocity_gradient;
  const std::size_t n = p.size();
  // The rotational springs (rebuild_pairs sizes them for a law that has them).
  double* const rolling = Law::rotational ? doubles(pl.rolling) : nullptr;
  double* const twist = Law::rotational ? pl.twist.data() : nullptr;
  double* const radius = Law::radius_history ? pl.contact_radius.data() : nullptr;  // (mindlin_rescale)
  ChunkIn in;
  ChunkOut out;
  using GatherFn = void (*)(const Particles&, const PairList&, Index, int, ChunkIn&);
#if defined(__x86_64__)
  const GatherFn gather = cpu_has_avx2 && !portable_gather ? &gather_chunk_avx2 : &gather_chunk;
#else
  const GatherFn gather = &gather_chunk;
#endif
  for (const std::size_t fb : blocks) {
    const std::size_t block_begin = fb * kForceBlock, block_end = std::min(n, (fb + 1) * kForceBlock);
    for (std::size_t first_owner = block_begin; first_owner < block_end; first_owner += kReductionBlock) {
      const std::size_t last_owner = std::min(block_end, first_owner + kReductionBlock);
      RunningSums sums;
      const Index begin = pl.first[first_owner], end = pl.first[last_owner];
      Index owner = static_cast<Index>(first_owner);
      for (Index q0 = begin; q0 < end; q0 += kChunk) {
        const int m = std::min<Index>(kChunk, end - q0);
        chunk_owners(pl.first.data(), q0, m, owner, in.owner);
        gather(p, pl, q0, m, in);
        evaluate_chunk<Law, K, Diagonal, Shear, Energy>(
            law, h, L, dt, m, in, pl.tangential[q0].data(), rolling ? rolling + 3 * q0 : nullptr,
            twist ? twist + q0 : nullptr, radius ? radius + q0 : nullptr, pl.force[q0].data(), pl.torque_i[q0].data(),
            pl.torque_j[q0].data(), out);
        sum_chunk<Shear, Energy>(out, q0, m, pl.flags.data(), sums);
      }
      ReductionSums& part = reduction_sums[first_owner / kReductionBlock];
      part.normal_sum = Vec3(sums.normal[0], sums.normal[1], sums.normal[2]);
      part.stiffness_sum = Vec3(sums.stiffness[0], sums.stiffness[1], sums.stiffness[2]);
      part.shear_sum = Vec3(sums.shear[0], sums.shear[1], sums.shear[2]);
      part.shear_stiffness_sum = Vec3(sums.shear_stiffness[0], sums.shear_stiffness[1], sums.shear_stiffness[2]);
      part.spin_sum = Vec3(sums.spin[0], sums.spin[1], sums.spin[2]);
      part.dissipation = Vec3(sums.dissipation[0], sums.dissipation[1], sums.dissipation[2]);
      part.touching = sums.touching;
    }
    if (blocks_done) blocks_done(block_begin, block_end);
  }
}

// The law's share function for the deck's law and the cell's shape: the one run-time choice of the loop.
// A loading with a shear servo takes the general cell (its tilts move; on a diagonal cell the general products
// give the same bits), so the shear sums cost one instantiation per law, not two.
// The energy budget needs the whole sum of force (x) branch: the general cell and the shear sums too.
template <class Law, Kinematics K>
ContactForceEvaluation::ShareFn share_for(bool diagonal, bool shear, bool energy) {
  if (energy) return &evaluate_share<Law, K, false, true, true>;
  if (shear) return &evaluate_share<Law, K, false, true, false>;
  return diagonal ? &evaluate_share<Law, K, true, false, false> : &evaluate_share<Law, K, false, false, false>;
}

}  // namespace

bool vector_gather_available() { return cpu_has_avx2; }
void use_portable_gather(bool portable) { portable_gather = portable; }

void ContactStressSum::add(Index owner, const Vec3& force, const Vec3& ds) {
  if (owner / kReductionBlock != block_) {
    total_ += block_sum_;
    block_sum_.setZero();
    block_ = owner / kReductionBlock;
  }
  const Real3 branch = apply<false>(h_, real3(ds));
  const double l[3] = {branch.x, branch.y, branch.z};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) block_sum_(r, c) += force[r] * l[c];
}

Mat3 ContactStressSum::stress(double volume) const {
  const Mat3 total = total_ + block_sum_;
  return 0.5 * (total + total.transpose()) / volume;
}

ContactForceEvaluation::ContactForceEvaluation(const Model& model, const Friction& friction, State& state,
                                               bool advance_slip, bool shear_sums)
    : params_(contact_params(model.contact, friction)),
      state_(state),
      dt_(advance_slip ? model.dt : 0.0),
      energy_(model.energy_budget),
      reduction_sums_((state.particles.size() + kReductionBlock - 1) / kReductionBlock) {
  const auto off_diagonal = [](const Mat3& m) { return (m - Mat3(m.diagonal().asDiagonal())).cwiseAbs().maxCoeff(); };
  const bool diagonal = off_diagonal(state.cell.h) == 0.0 && off_diagonal(state.cell.velocity_gradient) == 0.0;
  if (model.contact.rotational_history() && state.pairs.rolling.size() != state.pairs.size())
    throw std::logic_error("compute_contact_forces: the pair list has no rotational springs (rebuild it first)");
  if (model.contact.radius_history() && state.pairs.contact_radius.size() != state.pairs.size())
    throw std::logic_error("compute_contact_forces: the pair list has no contact radii (rebuild it first)");
  share_ = with_law(model.contact, [&](auto law) {
    using Law = decltype(law);
    return model.kinematics == Kinematics::Affine ? share_for<Law, Kinematics::Affine>(diagonal, shear_sums, energy_)
                                                  : share_for<Law, Kinematics::Lammps>(diagonal, shear_sums, energy_);
  });
}

void ContactForceEvaluation::evaluate_share(const std::vector<std::size_t>& blocks, const BlocksDone& blocks_done) {
  share_(params_, state_, dt_, reduction_sums_, blocks, blocks_done);
}

void ContactForceEvaluation::finish() {
  ReductionSums total;
  for (const ReductionSums& part : reduction_sums_) {
    total.normal_sum += part.normal_sum;
    total.stiffness_sum += part.stiffness_sum;
    total.shear_sum += part.shear_sum;
    total.shear_stiffness_sum += part.shear_stiffness_sum;
    total.spin_sum += part.spin_sum;
    total.dissipation += part.dissipation;
    total.touching += part.touching;
  }
  const double volume = state_.cell.volume();
  state_.stress << total.normal_sum / volume, total.shear_sum / volume;  // (shear: zero when not summed)
  state_.stiffness << total.stiffness_sum / volume, total.shear_stiffness_sum / volume;
  state_.touching = total.touching;
  if (energy_) add_to_energy_budget(total);
}

// The step's share of the energy budget (measure/energy.hpp): the cell's work on the contacts over the step by the
// trapezoid, -dt L : (M_old + M_new) / 2 with M = sum f (x) l, and what the contacts dissipated. At a stage's
// first evaluation (dt 0: nothing advanced) only M is kept.
void ContactForceEvaluation::add_to_energy_budget(const ReductionSums& total) {
  const Vec3& d = total.normal_sum;
  const Vec3& sym = total.shear_sum;
  const Vec3& anti = total.spin_sum;
  Mat3 moment;
  moment << d[0], sym[0] + anti[0], sym[1] + anti[1],  //
      sym[0] - anti[0], d[1], sym[2] + anti[2],        //
      sym[1] - anti[1], sym[2] - anti[2], d[2];
  EnergyLedger& e = state_.energy;
  if (e.open && dt_ > 0.0) {
    const Mat3 mean = 0.5 * (e.last_moment + moment);
    e.boundary_work -= dt_ * state_.cell.velocity_gradient.cwiseProduct(mean).sum();
  }
  e.friction += total.dissipation[0];
  e.rotational_friction += total.dissipation[1];
  e.contact_damping += total.dissipation[2];
  e.last_moment = moment;
}

void compute_contact_forces(const Model& model, const Friction& friction, State& state, bool advance_slip) {
  ContactForceEvaluation forces(model, friction, state, advance_slip);
#pragma omp parallel
  forces.evaluate_share(thread_force_blocks(state.pairs, state.particles.size()));
  forces.finish();
}

}  // namespace celldem
