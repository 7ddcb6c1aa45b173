#include "neighbor/neighbor_list.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/check.hpp"
#include "core/isa_clones.hpp"
#include "core/parallel.hpp"

namespace celldem {

Vec3 Cell::face_widths() const {
  const double v = std::abs(volume());
  Vec3 w;
  for (int k = 0; k < 3; ++k) w[k] = v / h.col((k + 1) % 3).cross(h.col((k + 2) % 3)).norm();
  return w;
}

namespace {

// The search tests |x_j + h m - x_i| < r_i + r_j + skin on the wrapped positions (m: the image between the
// bins): a subtraction and a dot product per candidate instead of h times a scaled difference. Its rounding
// differs from that of h (s_j - s_i + n) by some 1e-16 of the reach, so the reach is widened by far more:
// a pair at exactly r_i + r_j + skin may be listed (apart, it adds nothing), never one closer left out,
// which the rebuild criterion relies on.
constexpr double kReachMargin = 1.0 + 1e-12;

}  // namespace

PairSearch::PairSearch(const Model& model, const State& state)
    : state_(state), skin_(state.pairs.current_skin()), found_(omp_in_parallel() ? omp_get_num_threads() : omp_get_max_threads()) {
  const Particles& p = state.particles;
  const Mat3& h = state.cell.h;
  const std::size_t n = p.size();
  const double reach_max = 2.0 * model.max_radius + skin_;
  const Vec3 widths = state.cell.face_widths();
  for (int k = 0; k < 3; ++k)
    if (widths[k] <= 2.0 * reach_max)
      throw std::runtime_error("the periodic cell (face width " + std::to_string(widths[k]) +
                               " m) is too small for its particles: it must exceed twice the largest "
                               "diameter plus skin (" + std::to_string(2.0 * reach_max) + " m)");

  for (int k = 0; k < 3; ++k) bins_[k] = std::max(1, static_cast<int>(std::floor(widths[k] / reach_max)));
  use_bins_ = bins_[0] >= 3 && bins_[1] >= 3 && bins_[2] >= 3;
  if (!use_bins_) bins_ = {1, 1, 1};

  // Counting sort of particles into bins (CSR), particle order kept within a bin.
  const int nbins = bins_[0] * bins_[1] * bins_[2];
  bin_of_.resize(n);
  cell_of_.resize(n);
  wrapped_.resize(n);
  bin_first_.assign(nbins + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    int b[3];
    Vec3 w;
    for (int k = 0; k < 3; ++k) {
      const double whole = std::floor(p.scaled[i][k]);
      cell_of_[i][k] = static_cast<std::int32_t>(whole);
      w[k] = p.scaled[i][k] - whole;
      b[k] = std::clamp(static_cast<int>(w[k] * bins_[k]), 0, bins_[k] - 1);
    }
    wrapped_[i] = h * w;
    bin_of_[i] = (b[2] * bins_[1] + b[1]) * bins_[0] + b[0];
    ++bin_first_[bin_of_[i] + 1];
  }
  for (int b = 0; b < nbins; ++b) bin_first_[b + 1] += bin_first_[b];
  members_.resize(n);
  {
    std::vector<Index> fill(bin_first_.begin(), bin_first_.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      members_[fill[bin_of_[i]]++] = {{wrapped_[i][0], wrapped_[i][1], wrapped_[i][2]}, p.radius[i], static_cast<Index>(i)};
  }
  // The shift h m of each image m in {-1, 0, 1}^3, at (m_z + 1) * 9 + (m_y + 1) * 3 + m_x + 1.
  for (int m = 0; m < 27; ++m) shift_[m] = h * Vec3(m % 3 - 1.0, m / 3 % 3 - 1.0, m / 9 - 1.0);
  first_.assign(n + 1, 0);
}

void PairSearch::search_share() {
  const Particles& p = state_.particles;
  const std::size_t n = p.size();
  const double skin = skin_;
  std::vector<Candidate>& mine = found_[omp_get_thread_num()];
  const auto [begin, end] = thread_share(n, [](std::size_t k) { return k; });
  std::vector<Index> hits;  // the members that pass, by index into members_
  for (std::size_t i = begin; i < end; ++i) {
    const std::size_t row = mine.size();
    hits.clear();
    std::size_t hits_done = 0;
    const Vec3& xi = wrapped_[i];
    const double ri = p.radius[i];
    // Members [from, to) of the bin seen through image m (components -1, 0, 1). The test has no branch
    // (half the members fail j > i, at random): each member is written to the end of the row, which
    // grows only when it passes; the images are worked out for those alone.
    const auto search = [&](Index from, Index to, const std::array<std::int32_t, 3>& m) {
      const Vec3 target = xi - shift_[(m[2] + 1) * 9 + (m[1] + 1) * 3 + m[0] + 1];  // x_j + h m - x_i = x_j - target
      std::size_t passed = hits.size();
      hits.resize(passed + static_cast<std::size_t>(to - from));
      for (Index k = from; k < to; ++k) {
        const Member& c = members_[k];
        const double dx = c.x[0] - target[0], dy = c.x[1] - target[1], dz = c.x[2] - target[2];
        const double reach = (ri + c.radius + skin) * kReachMargin;
        hits[passed] = k;
        passed += static_cast<std::size_t>((c.id > static_cast<Index>(i)) & (dx * dx + dy * dy + dz * dz < reach * reach));
      }
      hits.resize(passed);
      for (std::size_t hit = hits_done; hit < passed; ++hit) {
        const Index j = members_[hits[hit]].id;
        // The stored image adds back the whole cells that the unwrapped positions carry, so that
        // s_j - s_i + n is the same vector.
        PairImage stored;
        for (int d = 0; d < 3; ++d) {
          const std::int32_t whole = m[d] + cell_of_[i][d] - cell_of_[j][d];
          if (whole < std::numeric_limits<std::int16_t>::min() || whole > std::numeric_limits<std::int16_t>::max())
            image_overflow_.store(true, std::memory_order_relaxed);  // (no throwing out of a parallel loop)
          stored[d] = static_cast<std::int16_t>(whole);
        }
        mine.push_back({j, stored});
      }
      hits_done = passed;
    };
    if (use_bins_) {
      const int bi = bin_of_[i];
      const int b[3] = {bi % bins_[0], (bi / bins_[0]) % bins_[1], bi / (bins_[0] * bins_[1])};
      // The three bins of a row along x are consecutive in bin order: one range of members, or two where
      // the row wraps around the cell (the part beyond the face seen through the image m_x = -1 or 1).
      for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy) {
          std::array<std::int32_t, 3> m{0, 0, 0};
          int w[3];
          for (int k = 1; k < 3; ++k) {
            const int u = b[k] + (k == 1 ? dy : dz);
            m[k] = u < 0 ? -1 : (u >= bins_[k] ? 1 : 0);
            w[k] = u - m[k] * bins_[k];
          }
          const int row_bin = (w[2] * bins_[1] + w[1]) * bins_[0];  // bin of x = 0 in this row
          const auto bins_x = [&](int lo, int hi) { return std::pair{bin_first_[row_bin + lo], bin_first_[row_bin + hi + 1]}; };
          const auto [from, to] = bins_x(std::max(b[0] - 1, 0), std::min(b[0] + 1, bins_[0] - 1));
          search(from, to, m);
          if (b[0] == 0 || b[0] == bins_[0] - 1) {
            m[0] = b[0] == 0 ? -1 : 1;
            const auto [wrap_from, wrap_to] = bins_x(b[0] == 0 ? bins_[0] - 1 : 0, b[0] == 0 ? bins_[0] - 1 : 0);
            search(wrap_from, wrap_to, m);
          }
        }
    } else {
      // Few bins: every image of every pair. The width check above allows at most one in reach.
      for (int m = 0; m < 27; ++m) search(0, static_cast<Index>(n), {m % 3 - 1, m / 3 % 3 - 1, m / 9 - 1});
    }
    std::sort(mine.begin() + static_cast<std::ptrdiff_t>(row), mine.end(),
              [](const Candidate& a, const Candidate& b) { return a.j < b.j; });
    first_[i + 1] = static_cast<Index>(mine.size() - row);  // the row's length until candidates() sums them
  }
}

PairSearch::Candidates PairSearch::candidates() {
  if (image_overflow_)
    throw std::runtime_error("two neighbours are more than 32767 cells apart in their unwrapped positions (more "
                             "than a pair image holds): particles have crossed the periodic cell that often only "
                             "if the sample was stirred far beyond any granular test");
  const std::size_t n = first_.size() - 1;
  Candidates out;
  out.first = std::move(first_);
  for (std::size_t i = 0; i < n; ++i) out.first[i + 1] += out.first[i];
  out.list.reserve(static_cast<std::size_t>(out.first[n]));
  // The threads' lists hold contiguous ranges of rows: joined in thread order, the rows are in particle order.
  for (const std::vector<Candidate>& f : found_) out.list.insert(out.list.end(), f.begin(), f.end());
  return out;
}

namespace {

// Each particle's incoming pairs in the order of its sum (PairList::incoming_pair): those owned in its force
// block, then those owned in earlier blocks, each in pair order.
void build_incoming(PairList& pl, std::size_t n) {
  pl.incoming_first.assign(n + 1, 0);
  for (const Index j : pl.neighbor) ++pl.incoming_first[static_cast<std::size_t>(j) + 1];
  for (std::size_t k = 0; k < n; ++k) pl.incoming_first[k + 1] += pl.incoming_first[k];
  pl.incoming_crossing.assign(pl.incoming_first.begin(), pl.incoming_first.end() - 1);
  for_each_pair(pl, [&](Index i, Index q) {
    const Index j = pl.neighbor[q];
    if (force_block(i) == force_block(j)) ++pl.incoming_crossing[static_cast<std::size_t>(j)];
  });
  pl.incoming_pair.resize(pl.neighbor.size());
  std::vector<Index> same(pl.incoming_first.begin(), pl.incoming_first.end() - 1);  // where the next one goes
  std::vector<Index> crossing(pl.incoming_crossing);
  for_each_pair(pl, [&](Index i, Index q) {
    const Index j = pl.neighbor[q];
    pl.incoming_pair[(force_block(i) == force_block(j) ? same : crossing)[static_cast<std::size_t>(j)]++] = q;
  });
}

}  // namespace

void rebuild_pairs(const Model& model, State& state) {
  PairSearch search(model, state);
#pragma omp parallel
  search.search_share();
  rebuild_pairs(model, state, search);
}

void rebuild_pairs(const Model& model, State& state, PairSearch& search) {
  Particles& p = state.particles;
  PairList& pl = state.pairs;
  const std::size_t n = p.size();
  const PairSearch::Candidates candidates = search.candidates();

  PairList next;
  next.skin = pl.skin;
  next.build_skin = search.skin();
  next.built_at_step = state.steps_since_creation;
  next.first = std::move(candidates.first);
  const std::size_t count = next.first[n];
  next.neighbor.resize(count);
  next.image.resize(count);
  next.tangential.assign(count, Vec3::Zero());
  const bool rotational = model.contact.rotational_history();
  next.rolling.assign(rotational ? count : 0, Vec3::Zero());
  next.twist.assign(rotational ? count : 0, 0.0);
  const bool carry_rotational = rotational && pl.rolling.size() == pl.size();
  const bool radius = model.contact.radius_history();
  next.contact_radius.assign(radius ? count : 0, 0.0);
  const bool carry_radius = radius && pl.contact_radius.size() == pl.size();
  next.flags.assign(count, 0);
  next.force.assign(count, Vec3::Zero());
  next.torque_i.assign(count, Vec3::Zero());
  next.torque_j.assign(count, Vec3::Zero());

  const bool have_old = pl.first.size() == n + 1;
  for (std::size_t i = 0; i < n; ++i) {
    // Both lists are sorted by j within i: a merge finds the persisting contacts.
    Index q_old = have_old ? pl.first[i] : 0;
    const Index q_old_end = have_old ? pl.first[i + 1] : 0;
    for (Index q = next.first[i]; q < next.first[i + 1]; ++q) {
      const Index j = candidates.list[q].j;
      next.neighbor[q] = j;
      next.image[q] = candidates.list[q].image;
      while (q_old < q_old_end && pl.neighbor[q_old] < j) ++q_old;
      if (q_old < q_old_end && pl.neighbor[q_old] == j) {
        next.tangential[q] = pl.tangential[q_old];
        next.flags[q] = pl.flags[q_old];
        if (carry_rotational) {
          next.rolling[q] = pl.rolling[q_old];
          next.twist[q] = pl.twist[q_old];
        }
        if (carry_radius) next.contact_radius[q] = pl.contact_radius[q_old];
      }
    }
  }
  build_incoming(next, n);
  next.scaled_at_build.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    next.scaled_at_build[i] = p.scaled[i].cast<float>();
    next.build_rounding = std::max(next.build_rounding,
                                   (p.scaled[i] - next.scaled_at_build[i].cast<double>()).cwiseAbs().maxCoeff());
  }
  next.h_at_build = state.cell.h;
  pl = std::move(next);
  if constexpr (kCheckInvariants) check_pair_list(pl, n);
}

void check_pair_list(const PairList& pl, std::size_t particles) {
  // Checked here whatever the build: tests call this to show the checks catch what they claim.
  const auto require = [](bool ok, const char* what) {
    if (!ok) detail::invariant_failed("check_pair_list", what, __FILE__, __LINE__);
  };
  const auto n = static_cast<Index>(particles);
  require(pl.first.size() == particles + 1 && pl.first[0] == 0, "first has N + 1 offsets from 0");
  const Index count = pl.first[n];
  const auto holds = [&](const auto& v) { return v.size() == static_cast<std::size_t>(count); };
  require(holds(pl.neighbor) && holds(pl.image) && holds(pl.tangential) && holds(pl.flags) && holds(pl.force) &&
              holds(pl.torque_i) && holds(pl.torque_j),
          "every per-pair array holds first[N] pairs");
  require((pl.rolling.empty() || holds(pl.rolling)) && (pl.twist.empty() || holds(pl.twist)) &&
              (pl.contact_radius.empty() || holds(pl.contact_radius)),
          "the optional per-pair arrays are empty or hold first[N] pairs");
  for (Index i = 0; i < n; ++i) {
    require(pl.first[i] <= pl.first[i + 1], "first is non-decreasing");
    for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q) {
      const Index j = pl.neighbor[q];
      require(j > i && j < n, "a neighbour has a higher id than its owner");
      require(q == pl.first[i] || pl.neighbor[q - 1] < j, "a row's neighbours are strictly increasing");
    }
  }
  require(pl.incoming_first.size() == particles + 1 && pl.incoming_first[0] == 0 && pl.incoming_first[n] == count &&
              pl.incoming_crossing.size() == particles && holds(pl.incoming_pair),
          "the incoming arrays hold every pair once");
  // Each pair's owner, to check every incoming pair's place in its neighbour's sum.
  std::vector<Index> owner(static_cast<std::size_t>(count), -1);
  for_each_pair(pl, [&](Index i, Index q) { owner[static_cast<std::size_t>(q)] = i; });
  std::vector<int> seen(static_cast<std::size_t>(count), 0);
  for (Index j = 0; j < n; ++j) {
    require(pl.incoming_first[j] <= pl.incoming_crossing[j] && pl.incoming_crossing[j] <= pl.incoming_first[j + 1],
            "a particle's crossing pairs lie within its incoming pairs");
    for (Index k = pl.incoming_first[j]; k < pl.incoming_first[j + 1]; ++k) {
      const Index q = pl.incoming_pair[k];
      require(q >= 0 && q < count && pl.neighbor[q] == j, "incoming_pair points at the pairs of j");
      require(++seen[static_cast<std::size_t>(q)] == 1, "the incoming arrays hold every pair once");
      const bool crossing = k >= pl.incoming_crossing[j];
      require(crossing == (force_block(owner[static_cast<std::size_t>(q)]) < force_block(j)),
              "j's pairs owned in its force block come first, those owned in earlier blocks after them");
      require(k == pl.incoming_first[j] || k == pl.incoming_crossing[j] || pl.incoming_pair[k - 1] < q,
              "the pairs coming into j are in pair order");
    }
  }
}

double largest_move_since_build(const State& state) {
  const PairList& pl = state.pairs;
  const Particles& p = state.particles;
  if (pl.first.size() != p.size() + 1 || pl.scaled_at_build.size() != p.size())
    return std::numeric_limits<double>::infinity();
  double max_disp2 = 0.0;  // a maximum: the same whatever the order, so the threads may split the work
  const std::size_t n = p.size(), blocks = (n + kForceBlock - 1) / kForceBlock;
#pragma omp parallel for schedule(static) reduction(max : max_disp2)
  for (std::size_t b = 0; b < blocks; ++b)
    max_disp2 = std::max(max_disp2, largest_move2(state.cell.h, p, pl, b * kForceBlock, std::min(n, (b + 1) * kForceBlock)));
  return std::sqrt(max_disp2);
}

// On plain arrays in SIMD lanes (as scalar code on 3-vectors it took most of the drift's time). A maximum is the
// same in any order; each particle's value is summed as Eigen's (h * d).squaredNorm(): rows 1 and 2 of h d left
// to right, row 3 as a + (b + c) (tests/neighbor/test_neighbor_list.cpp checks it bit for bit).
CELLDEM_ISA_CLONES
double largest_move2(const Mat3& h, const Particles& p, const PairList& pl, std::size_t begin, std::size_t end) {
  if (begin >= end) return 0.0;
  const double* const __restrict s = p.scaled[begin].data();
  const float* const __restrict at_build = pl.scaled_at_build[begin].data();
  const double h00 = h(0, 0), h01 = h(0, 1), h02 = h(0, 2), h10 = h(1, 0), h11 = h(1, 1), h12 = h(1, 2),
               h20 = h(2, 0), h21 = h(2, 1), h22 = h(2, 2);
  double largest = 0.0;
  CELLDEM_SIMD(reduction(max : largest))
  for (std::size_t i = 0; i < end - begin; ++i) {
    const double dx = s[3 * i] - static_cast<double>(at_build[3 * i]);
    const double dy = s[3 * i + 1] - static_cast<double>(at_build[3 * i + 1]);
    const double dz = s[3 * i + 2] - static_cast<double>(at_build[3 * i + 2]);
    const double x = h00 * dx + h01 * dy + h02 * dz, y = h10 * dx + h11 * dy + h12 * dz,
                 z = h20 * dx + (h21 * dy + h22 * dz);
    largest = std::max(largest, x * x + y * y + z * z);
  }
  return largest;
}

bool pairs_need_rebuild(const Model& model, const State& state) {
  return pairs_need_rebuild(model, state, largest_move_since_build(state));
}

bool pairs_need_rebuild(const Model& model, const State& state, double largest_move) {
  const PairList& pl = state.pairs;
  if (pl.first.size() != state.particles.size() + 1 || !std::isfinite(largest_move)) return true;
  // A pair left out at the build was at least r_i + r_j + skin apart. Since then its branch has been
  // mapped by F = h h_build^-1 and each end moved by at most largest_move, so it is still apart while
  // (1 - |F - I|) (r_i + r_j + skin) - 2 largest_move > r_i + r_j, hardest for the largest pair.
  const double strain = (state.cell.h * pl.h_at_build.inverse() - Mat3::Identity()).norm();  // Frobenius >= spectral
  const double reach = 2.0 * model.max_radius;
  // The move was measured from the build positions as stored (single precision): add what their rounding
  // can hide, |h e| <= |h|_F sqrt(3) build_rounding.
  const double hidden = state.cell.h.norm() * std::sqrt(3.0) * pl.build_rounding;
  return (1.0 - strain) * (reach + pl.current_skin()) - 2.0 * (largest_move + hidden) <= reach;
}

void adapt_skin(State& state) {
  PairList& pl = state.pairs;
  const auto lasted = static_cast<double>(state.steps_since_creation - pl.built_at_step);
  if (pl.first.empty() || lasted <= 0.0) return;
  const double factor = std::clamp(kSkinLifetime / lasted, 0.5, 2.0);
  pl.build_skin = std::clamp(pl.current_skin() * factor, pl.skin * kSmallestSkin, pl.skin);
}

void set_stored_contacts(State& state, const std::vector<StoredContact>& contacts) {
  const std::size_t n = state.particles.size();
  PairList& pl = state.pairs;
  const double skin = pl.skin;
  pl = PairList{};
  pl.skin = skin;
  pl.first.assign(n + 1, 0);
  for (const auto& c : contacts) ++pl.first[c.i + 1];
  for (std::size_t k = 0; k < n; ++k) pl.first[k + 1] += pl.first[k];
  pl.neighbor.resize(contacts.size());
  pl.tangential.resize(contacts.size());
  const bool rotational = std::any_of(contacts.begin(), contacts.end(),
                                      [](const StoredContact& c) { return !c.rolling.isZero(0.0) || c.twist != 0.0; });
  pl.rolling.assign(rotational ? contacts.size() : 0, Vec3::Zero());
  pl.twist.assign(rotational ? contacts.size() : 0, 0.0);
  const bool radius = std::any_of(contacts.begin(), contacts.end(),
                                  [](const StoredContact& c) { return c.contact_radius != 0.0; });
  pl.contact_radius.assign(radius ? contacts.size() : 0, 0.0);
  pl.flags.resize(contacts.size());
  pl.image.assign(contacts.size(), {0, 0, 0});  // unknown until the next rebuild, which must come first
  pl.force.assign(contacts.size(), Vec3::Zero());
  pl.torque_i.assign(contacts.size(), Vec3::Zero());
  pl.torque_j.assign(contacts.size(), Vec3::Zero());
  std::vector<Index> fill(pl.first.begin(), pl.first.end() - 1);
  for (const auto& c : contacts) {  // contacts arrive sorted by (i, j), so each row stays sorted
    const Index q = fill[c.i]++;
    pl.neighbor[q] = c.j;
    pl.tangential[q] = c.tangential;
    pl.flags[q] = c.flags;
    if (rotational) {
      pl.rolling[q] = c.rolling;
      pl.twist[q] = c.twist;
    }
    if (radius) pl.contact_radius[q] = c.contact_radius;
  }
}

std::vector<StoredContact> stored_contacts(const State& state) {
  const PairList& pl = state.pairs;
  std::vector<StoredContact> out;
  for_each_pair(pl, [&](Index i, Index q) {
    if (!(pl.flags[q] & kTouching)) return;
    StoredContact c{i, pl.neighbor[q], pl.tangential[q], pl.flags[q]};
    if (pl.rolling.size() == pl.size()) {
      c.rolling = pl.rolling[q];
      c.twist = pl.twist[q];
    }
    if (pl.contact_radius.size() == pl.size()) c.contact_radius = pl.contact_radius[q];
    out.push_back(c);
  });
  return out;
}

}  // namespace celldem
