// The neighbour list (solver/neighbor/neighbor_list.hpp) against a brute-force search over all pairs and
// all periodic images; the rebuild criterion against the same brute force along a random trajectory of a
// deforming cell; history carried over a rebuild; and the stored-contact round trip.
#include <algorithm>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <optional>
#include <random>
#include <set>
#include <stdexcept>
#include <tuple>

#include "helpers.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {
namespace {

// The largest move since the build, on plain arrays in SIMD lanes, is |h (s - s_build)| as Eigen computes it,
// to the bit: in each trial one particle of 67 has moved, at a random place in the SIMD loop, and the others sit
// at their build positions, so the largest move is that particle's own value, computed here with Eigen.
TEST(NeighborList, LargestMoveIsEigensNormOfTheMoveToTheBit) {
  const std::size_t n = 67;
  std::mt19937_64 gen(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Mat3 h = (Mat3() << 4.001, 0.3002, -0.2001, 0.1003, 4.998, 0.4001, -0.2998, 0.1997, 6.0005).finished();
  int differ = 0;
  for (int trial = 0; trial < 200; ++trial) {
    State s = testing::make_state(h, std::vector<double>(n, 0.01), std::vector<Vec3>(n, Vec3::Zero()), 0.1);
    s.pairs = PairList{};
    s.pairs.first.assign(n + 1, 0);
    s.pairs.scaled_at_build.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      s.pairs.scaled_at_build[i] = (testing::draw_vec3(u, gen) * 3.0).cast<float>();
      s.particles.scaled[i] = s.pairs.scaled_at_build[i].cast<double>();  // (not moved: a zero displacement)
    }
    const std::size_t moved = gen() % n;
    s.particles.scaled[moved] += testing::draw_vec3(u, gen) * std::pow(10.0, -3.0 + 2.0 * u(gen));
    const Vec3 d = s.particles.scaled[moved] - s.pairs.scaled_at_build[moved].cast<double>();
    differ += largest_move_since_build(s) != std::sqrt((h * d).squaredNorm());
  }
  EXPECT_EQ(differ, 0) << "trials of 200 where the largest move differs from Eigen's |h d| of the moved particle";
}

using testing::model_deck;
using Key = std::tuple<Index, Index, int, int, int>;  // (i, j, total image shift n)

// Every (i < j, image) with |h (s_j - s_i + n)| < r_i + r_j + extra, by trying every image near the
// closest one. Independent of the bins and of how positions are wrapped.
std::set<Key> brute_force(const State& s, double extra, int range = 1) {
  std::set<Key> out;
  const auto& p = s.particles;
  for (std::size_t i = 0; i < p.size(); ++i)
    for (std::size_t j = i + 1; j < p.size(); ++j) {
      const Vec3 ds = p.scaled[j] - p.scaled[i];
      const Vec3 base = (-ds).array().round();
      for (int dz = -range; dz <= range; ++dz)
        for (int dy = -range; dy <= range; ++dy)
          for (int dx = -range; dx <= range; ++dx) {
            const Vec3 n = base + Vec3(dx, dy, dz);
            const double reach = p.radius[i] + p.radius[j] + extra;
            if ((s.cell.h * (ds + n)).squaredNorm() < reach * reach)
              out.insert({static_cast<Index>(i), static_cast<Index>(j), static_cast<int>(n[0]),
                          static_cast<int>(n[1]), static_cast<int>(n[2])});
          }
    }
  return out;
}

std::set<Key> listed(const PairList& pl) {
  std::set<Key> out;
  for_each_pair(pl, [&](Index i, Index q) {
    out.insert({i, pl.neighbor[q], pl.image[q][0], pl.image[q][1], pl.image[q][2]});
  });
  return out;
}

// A random polydisperse packing in the cell h, positions shifted by random whole cells (unwrapped).
State random_state(const Mat3& h, int n, double rmin, double rmax, std::uint64_t seed, double skin) {
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_int_distribution<int> whole(-3, 3);
  State s;
  s.cell.h = h;
  s.particles.resize(n);
  s.pairs.skin = skin;
  auto coordinate = [&](std::mt19937_64& g) {  // a fraction, then a whole number of cells, in this order
    const double fraction = u(g);
    return fraction + whole(g);
  };
  for (int i = 0; i < n; ++i) {
    s.particles.radius[i] = rmin + (rmax - rmin) * u(gen);
    s.particles.scaled[i] = testing::draw_vec3(coordinate, gen);
  }
  return s;
}

void expect_list_consistent(const PairList& pl, std::size_t n) {
  ASSERT_EQ(pl.first.size(), n + 1);
  EXPECT_EQ(pl.first[0], 0);
  EXPECT_EQ(static_cast<std::size_t>(pl.first[n]), pl.size());
  for (std::size_t i = 0; i < n; ++i)
    for (Index q = pl.first[i]; q < pl.first[i + 1]; ++q) {
      EXPECT_EQ(pl.owner_of(q), static_cast<Index>(i));
      EXPECT_GT(pl.neighbor[q], static_cast<Index>(i));
      if (q > pl.first[i]) { EXPECT_LT(pl.neighbor[q - 1], pl.neighbor[q]); }  // sorted by j, one image each
    }
  // The incoming pairs: under each neighbour j, first the pairs whose owner is in j's force block, then those
  // whose owner is in an earlier block (crossing pairs), each in pair order.
  std::vector<std::vector<Index>> same(n), crossing(n);
  for_each_pair(pl, [&](Index i, Index q) {
    const Index j = pl.neighbor[q];
    (i / kForceBlock == j / kForceBlock ? same : crossing)[j].push_back(q);
  });
  ASSERT_EQ(pl.incoming_first.size(), n + 1);
  ASSERT_EQ(pl.incoming_crossing.size(), n);
  ASSERT_EQ(pl.incoming_pair.size(), pl.size());
  std::size_t crossings = 0;
  for (std::size_t j = 0; j < n; ++j) {
    std::vector<Index> expected = same[j];
    expected.insert(expected.end(), crossing[j].begin(), crossing[j].end());
    const std::vector<Index> got(pl.incoming_pair.begin() + pl.incoming_first[j],
                                 pl.incoming_pair.begin() + pl.incoming_first[j + 1]);
    EXPECT_EQ(got, expected) << "particle " << j;
    EXPECT_EQ(pl.incoming_crossing[j] - pl.incoming_first[j], static_cast<Index>(same[j].size())) << "particle " << j;
    crossings += crossing[j].size();
  }
  EXPECT_EQ(pl.crossings(), crossings);
}

struct CellCase {
  const char* name;
  Mat3 h;
  int n;
};

TEST(NeighborList, MatchesBruteForceInCubicShearedAndSmallCells) {
  const CellCase cases[] = {
      {"cubic, binned", Mat3::Identity() * 10.0, 400},
      {"sheared, binned", (Mat3() << 9.0, 2.5, -1.0, 0.0, 10.0, 1.5, 0.0, 0.0, 9.5).finished(), 400},
      {"cubic, two force blocks", Mat3::Identity() * 18.5, 2600},
      {"small, all pairs", Mat3::Identity() * 3.0, 20},
      {"thin sheared, all pairs", (Mat3() << 3.0, 1.0, 0.0, 0.0, 3.2, 0.0, 0.0, 0.0, 8.0).finished(), 40},
  };
  for (const CellCase& c : cases) {
    SCOPED_TRACE(c.name);
    const double skin = 0.15;
    State s = random_state(c.h, c.n, 0.3, 0.6, 5, skin);
    const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
    rebuild_pairs(model, s);
    expect_list_consistent(s.pairs, s.particles.size());
    if (s.particles.size() > kForceBlock) { EXPECT_GT(s.pairs.crossings(), 100u); }
    const std::set<Key> expected = brute_force(s, skin);
    EXPECT_EQ(listed(s.pairs), expected);
    EXPECT_GT(expected.size(), 10u);
    for (std::size_t q = 0; q < s.pairs.size(); ++q) {  // histories start empty
      EXPECT_EQ(s.pairs.tangential[q], Vec3::Zero());
      EXPECT_EQ(s.pairs.flags[q], 0);
    }
  }
}

// The invariant check (run after every build in the checking build) passes a built list across two force
// blocks and stops, naming the invariant, on each kind of corruption the pair loop and the kick could not survive.
TEST(NeighborListDeathTest, InvariantCheckCatchesBrokenLists) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  State s = random_state(Mat3::Identity() * 18.5, 2600, 0.3, 0.6, 5, 0.15);
  rebuild_pairs(make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius), s);
  const std::size_t n = s.particles.size();
  check_pair_list(s.pairs, n);  // a built list passes
  ASSERT_GT(s.pairs.crossings(), 1u);
  std::size_t row = 0;  // a particle with at least two neighbours
  while (s.pairs.first[row + 1] - s.pairs.first[row] < 2) ++row;

  PairList unsorted = s.pairs;
  std::swap(unsorted.neighbor[unsorted.first[row]], unsorted.neighbor[unsorted.first[row] + 1]);
  EXPECT_DEATH(check_pair_list(unsorted, n), "strictly increasing");
  PairList short_forces = s.pairs;
  short_forces.force.pop_back();
  EXPECT_DEATH(check_pair_list(short_forces, n), "every per-pair array");
  PairList short_torques = s.pairs;
  short_torques.torque_j.pop_back();
  EXPECT_DEATH(check_pair_list(short_torques, n), "every per-pair array");
  PairList lost_incoming = s.pairs;
  lost_incoming.incoming_pair.pop_back();
  EXPECT_DEATH(check_pair_list(lost_incoming, n), "hold every pair once");
  PairList wrong_incoming = s.pairs;
  std::swap(wrong_incoming.incoming_pair.front(), wrong_incoming.incoming_pair.back());
  EXPECT_DEATH(check_pair_list(wrong_incoming, n), "incoming_pair points at the pairs of j");
  // A particle with pairs coming in from its own block and from an earlier one: moving the split between
  // them by one would sum a pair in the wrong place.
  std::size_t j = kForceBlock;
  while (s.pairs.incoming_crossing[j] == s.pairs.incoming_first[j] ||
         s.pairs.incoming_crossing[j] == s.pairs.incoming_first[j + 1])
    ASSERT_LT(++j, n);
  PairList wrong_split = s.pairs;
  ++wrong_split.incoming_crossing[j];
  EXPECT_DEATH(check_pair_list(wrong_split, n), "come first");
  PairList wrong_order = s.pairs;  // two of j's own-block pairs swapped: the sum's order would change
  std::size_t k = 0;
  while (s.pairs.incoming_crossing[k] - s.pairs.incoming_first[k] < 2) ASSERT_LT(++k, n);
  std::swap(wrong_order.incoming_pair[wrong_order.incoming_first[k]], wrong_order.incoming_pair[wrong_order.incoming_first[k] + 1]);
  EXPECT_DEATH(check_pair_list(wrong_order, n), "in pair order");
}

// The search shared among the threads of a region the caller owns (as the time step runs it) gives the same
// list, row for row, as rebuild_pairs on its own, on any number of threads.
TEST(NeighborList, SearchSharedInACallersRegionGivesTheSameList) {
  State reference = random_state((Mat3() << 9.0, 2.5, -1.0, 0.0, 10.0, 1.5, 0.0, 0.0, 9.5).finished(), 700, 0.3, 0.6, 9, 0.15);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), reference.particles.radius);
  rebuild_pairs(model, reference);
  for (int threads = 1; threads <= 4; ++threads) {
    SCOPED_TRACE(threads);
    State s = reference;
    s.pairs = PairList{};
    s.pairs.skin = reference.pairs.skin;
    std::optional<PairSearch> search;
#pragma omp parallel num_threads(threads)
    {
#pragma omp single
      search.emplace(model, s);  // (an implicit barrier follows)
      search->search_share();
#pragma omp barrier
#pragma omp single
      rebuild_pairs(model, s, *search);
    }
    EXPECT_EQ(s.pairs.first, reference.pairs.first);
    EXPECT_EQ(s.pairs.neighbor, reference.pairs.neighbor);
    EXPECT_EQ(s.pairs.image, reference.pairs.image);
    EXPECT_EQ(s.pairs.incoming_pair, reference.pairs.incoming_pair);
    EXPECT_EQ(s.pairs.incoming_crossing, reference.pairs.incoming_crossing);
  }
}

TEST(NeighborList, CellTooSmallForParticlesThrows) {
  State s = random_state(Mat3::Identity() * 2.0, 4, 0.5, 0.5, 1, 0.1);  // width 2 <= 2 (1 + 0.1)
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  EXPECT_THROW(rebuild_pairs(model, s), std::runtime_error);
}

TEST(NeighborList, ImagesBeyondSixteenBitsAreRefusedNotWrapped) {
  // A lattice with one sphere carried 40,000 cells away in its unwrapped position: the same contacts,
  // but images the pair arrays cannot hold.
  State s = testing::lattice_state(4, 0.5, Vec3(0.98, 0.98, 0.98), 0.1);
  const Model model = make_model(testing::model_deck(1e4, 1e4, 1e-3), s.particles.radius);
  rebuild_pairs(model, s);
  EXPECT_GT(s.pairs.size(), 0u);
  s.particles.scaled[5].x() += 40000.0;
  EXPECT_THROW(rebuild_pairs(model, s), std::runtime_error);
  s.particles.scaled[5].x() -= 40000.0 - 30000.0;  // 30,000 cells: still held, and the same pairs
  const std::size_t pairs = s.pairs.size();
  rebuild_pairs(model, s);
  EXPECT_EQ(s.pairs.size(), pairs);
}

TEST(NeighborList, HistoryCarriedOverRebuild) {
  State s = random_state(Mat3::Identity() * 8.0, 200, 0.35, 0.55, 9, 0.2);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  // Plant a history on every listed pair, keyed by its ids.
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    s.pairs.tangential[q] = Vec3(s.pairs.owner_of(q), s.pairs.neighbor[q], 1.0) * 1e-6;
    s.pairs.flags[q] = kTouching | (q % 2 ? kSliding : 0);
  }
  const PairList before = s.pairs;
  // Move every particle a little: some pairs leave the list, the others keep their history.
  std::mt19937_64 gen(3);
  std::normal_distribution<double> g(0.0, 0.01);
  for (auto& x : s.particles.scaled) x += testing::draw_vec3(g, gen);
  rebuild_pairs(model, s);
  int kept = 0;
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    const int old = testing::find_pair(before, s.pairs.owner_of(q), s.pairs.neighbor[q]);
    if (old < 0) {
      EXPECT_EQ(s.pairs.tangential[q], Vec3::Zero());
      EXPECT_EQ(s.pairs.flags[q], 0);
    } else {
      EXPECT_EQ(s.pairs.tangential[q], before.tangential[old]);
      EXPECT_EQ(s.pairs.flags[q], before.flags[old]);
      ++kept;
    }
  }
  EXPECT_GT(kept, 50);
  EXPECT_LT(static_cast<std::size_t>(kept), s.pairs.size());  // the move changed the list
}

// Along a random trajectory (particle moves and cell deformation), whenever pairs_need_rebuild says the
// list is still good, every pair actually in contact (brute force) is in it.
TEST(NeighborList, RebuildCriterionNeverMissesAContact) {
  const double skin = 0.1;
  State s = random_state(Mat3::Identity() * 6.0, 150, 0.3, 0.5, 21, skin);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  std::mt19937_64 gen(4);
  std::normal_distribution<double> g(0.0, 1.0);
  rebuild_pairs(model, s);
  std::set<Key> have = listed(s.pairs);  // the list changes only at a rebuild
  int checks = 0, rebuilds = 0;
  for (int it = 0; it < 120; ++it) {
    // A small random step of the cell (stretch and shear) and of each particle.
    Mat3 F = Mat3::Identity();
    for (int k = 0; k < 9; ++k) F.data()[k] += 2e-3 * g(gen);
    s.cell.h = F * s.cell.h;
    const Mat3 hinv = s.cell.h.inverse();
    for (auto& x : s.particles.scaled) x += hinv * testing::draw_vec3(g, gen) * 4e-3;
    if (pairs_need_rebuild(model, s)) {
      rebuild_pairs(model, s);
      have = listed(s.pairs);
      ++rebuilds;
      continue;
    }
    ++checks;
    const std::set<Key> touching = brute_force(s, 0.0);
    for (const Key& k : touching) EXPECT_TRUE(have.count(k)) << "missed pair " << std::get<0>(k) << "-" << std::get<1>(k);
  }
  EXPECT_GT(checks, 20);   // the criterion does allow steps without a rebuild...
  EXPECT_GT(rebuilds, 2);  // ...and asks for rebuilds
}

// The skin adapts to the list's lifetime: halved at most when a list lasted long, doubled at most when it
// lasted briefly, never above the deck's skin nor below kSmallestSkin of it.
TEST(NeighborList, AdaptedSkinFollowsTheListsLifetime) {
  State s = random_state(Mat3::Identity() * 7.0, 30, 0.3, 0.5, 2, 0.1);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  EXPECT_EQ(s.pairs.current_skin(), 0.1);  // the first build: the deck's skin
  const auto lasting = [&](double steps) {
    s.steps_since_creation = s.pairs.built_at_step + static_cast<std::int64_t>(steps);
    adapt_skin(s);
    rebuild_pairs(model, s);
    return s.pairs.current_skin();
  };
  EXPECT_DOUBLE_EQ(lasting(kSkinLifetime * 1.5), 0.1 / 1.5);
  EXPECT_DOUBLE_EQ(lasting(kSkinLifetime * 10.0), 0.1 / 1.5 / 2.0);  // at most halved
  EXPECT_DOUBLE_EQ(lasting(kSkinLifetime / 10.0), 0.1 / 1.5);         // at most doubled
  EXPECT_DOUBLE_EQ(lasting(kSkinLifetime / 10.0), 0.1);               // never above the deck's
  for (int k = 0; k < 10; ++k) lasting(kSkinLifetime * 10.0);
  EXPECT_DOUBLE_EQ(s.pairs.current_skin(), 0.1 * kSmallestSkin);
  s.pairs.skin = 0.002;  // a new stage's deck with a smaller skin caps the adapted one
  EXPECT_EQ(s.pairs.current_skin(), 0.002);
}

// As RebuildCriterionNeverMissesAContact, with the skin adapted at every rebuild under slow motion (lists
// that last long, so the skin shrinks to a fraction of the deck's).
TEST(NeighborList, AdaptedSkinNeverMissesAContact) {
  State s = random_state(Mat3::Identity() * 6.0, 150, 0.3, 0.5, 21, 0.1);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  std::mt19937_64 gen(7);
  std::normal_distribution<double> g(0.0, 1.0);
  rebuild_pairs(model, s);
  std::set<Key> have = listed(s.pairs);
  // Each particle drifts at its own steady velocity, the cell at a steady rate of stretch and shear.
  std::vector<Vec3> velocity(s.particles.size());
  for (Vec3& v : velocity) v = testing::draw_vec3(g, gen) * 2e-5;
  Mat3 F = Mat3::Identity();
  for (int k = 0; k < 9; ++k) F.data()[k] += 1e-5 * g(gen);
  int checks = 0, rebuilds = 0;
  for (int step = 0; step < 3000; ++step, ++s.steps_since_creation) {
    s.cell.h = F * s.cell.h;
    const Mat3 hinv = s.cell.h.inverse();
    for (std::size_t i = 0; i < velocity.size(); ++i) s.particles.scaled[i] += hinv * velocity[i];
    if (pairs_need_rebuild(model, s)) {
      adapt_skin(s);
      rebuild_pairs(model, s);
      have = listed(s.pairs);
      ++rebuilds;
      continue;
    }
    if (step % 20 != 0) continue;
    ++checks;
    for (const Key& k : brute_force(s, 0.0)) EXPECT_TRUE(have.count(k)) << "missed pair " << std::get<0>(k) << "-" << std::get<1>(k);
  }
  EXPECT_LT(s.pairs.current_skin(), 0.05);  // it did shrink...
  EXPECT_GT(rebuilds, 5);                   // ...and the shrunk lists were rebuilt in time
  EXPECT_GT(checks, 100);
}

TEST(NeighborList, NeedsRebuildWhenListDoesNotMatchParticles) {
  State s = random_state(Mat3::Identity() * 7.0, 30, 0.3, 0.5, 2, 0.1);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  EXPECT_TRUE(pairs_need_rebuild(model, s));  // never built
  rebuild_pairs(model, s);
  EXPECT_FALSE(pairs_need_rebuild(model, s));  // nothing moved
  // One particle moves by more than half the skin: two such ends could close it, so a rebuild is needed.
  s.particles.scaled[0] += s.cell.h.inverse() * Vec3(0.06, 0.0, 0.0);
  EXPECT_TRUE(pairs_need_rebuild(model, s));
}

TEST(NeighborList, StoredContactsRoundTrip) {
  State s = random_state(Mat3::Identity() * 8.0, 200, 0.4, 0.6, 13, 0.1);
  const Model model = make_model(model_deck(1e4, 1e4, 1e-4), s.particles.radius);
  rebuild_pairs(model, s);
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    s.pairs.flags[q] = q % 3 ? kTouching : 0;
    if (q % 3) s.pairs.tangential[q] = Vec3(q, -1.0, 0.5) * 1e-7;
    if (q % 5 == 0) s.pairs.flags[q] |= kSliding;
  }
  const std::vector<StoredContact> stored = stored_contacts(s);
  ASSERT_FALSE(stored.empty());
  for (std::size_t c = 1; c < stored.size(); ++c)
    EXPECT_TRUE(std::tie(stored[c - 1].i, stored[c - 1].j) < std::tie(stored[c].i, stored[c].j));
  State t = s;
  set_stored_contacts(t, stored);
  EXPECT_EQ(t.pairs.skin, s.pairs.skin);
  const std::vector<StoredContact> again = stored_contacts(t);
  ASSERT_EQ(again.size(), stored.size());
  for (std::size_t c = 0; c < stored.size(); ++c) {
    EXPECT_EQ(again[c].i, stored[c].i);
    EXPECT_EQ(again[c].j, stored[c].j);
    EXPECT_EQ(again[c].tangential, stored[c].tangential);
    EXPECT_EQ(again[c].flags, stored[c].flags);
  }
  // The next rebuild merges the stored history into the full list: the same list with the same history.
  rebuild_pairs(model, t);
  EXPECT_EQ(listed(t.pairs), listed(s.pairs));
  for (std::size_t q = 0; q < s.pairs.size(); ++q) {
    const int r = testing::find_pair(t.pairs, s.pairs.owner_of(q), s.pairs.neighbor[q]);
    ASSERT_GE(r, 0);
    if (s.pairs.flags[q] & kTouching) {
      EXPECT_EQ(t.pairs.tangential[r], s.pairs.tangential[q]);
      EXPECT_EQ(t.pairs.flags[r], s.pairs.flags[q]);
    } else {
      EXPECT_EQ(t.pairs.flags[r], 0);
    }
  }
}

}  // namespace
}  // namespace celldem
