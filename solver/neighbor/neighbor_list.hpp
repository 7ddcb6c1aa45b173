// Half neighbour list with periodic images, built in the cell's scaled coordinates with a skin, and the
// criterion that says when it must be rebuilt (particle motion and cell deformation together).
#pragma once
#include <array>
#include <atomic>
#include <cstdint>
#include <vector>

#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Rebuilds state.pairs for the current positions: lists every pair closer than r_i + r_j + skin
// (skin: state.pairs.current_skin()) and carries over the contact history of pairs that persist.
// Throws std::runtime_error if the cell has become too small for its particles (a pair would touch twice).
void rebuild_pairs(const Model& model, State& state);

// The same in three parts, for a parallel region the caller owns (the time step's): one thread constructs
// the search (it sorts the particles into bins, and throws as rebuild_pairs does), every thread of the
// region calls search_share(), then one thread calls rebuild_pairs(model, state, search). The lists are
// the same for any number of threads.
class PairSearch {
 public:
  PairSearch(const Model& model, const State& state);
  void search_share();  // the calling thread's share of the particles' rows
  double skin() const { return skin_; }

  struct Candidate {
    Index j;
    PairImage image;
  };
  // Each particle's neighbours j > i (any image) within r_i + r_j + skin, sorted by j: the rows of a CSR.
  struct Candidates {
    std::vector<Index> first;  // (N+1)
    std::vector<Candidate> list;
  };
  Candidates candidates();  // once, after every share is searched; throws if a pair image overflowed

 private:
  // A particle as the search reads it, stored in bin order so that a bin's members lie side by side: its
  // position wrapped into the cell, in metres (x = h w, w = s - floor(s)), its radius and id.
  struct Member {
    double x[3];
    double radius;
    Index id;
  };
  const State& state_;
  double skin_;                                          // [m]
  std::array<int, 3> bins_;                              // along each cell vector
  bool use_bins_;                                        // false: too few bins; every pair is tested
  std::vector<int> bin_of_;                              // (N)
  std::vector<std::array<std::int32_t, 3>> cell_of_;     // (N) floor of the unwrapped scaled position
  std::vector<Vec3> wrapped_;                            // (N) h (s - floor(s)) [m]
  std::vector<Index> bin_first_;                         // (bins + 1) CSR of members_ by bin
  std::vector<Member> members_;                          // (N) in bin order
  std::array<Vec3, 27> shift_;                           // h m for each image m in {-1, 0, 1}^3 [m]
  std::vector<std::vector<Candidate>> found_;            // per thread: its rows, in particle order
  std::vector<Index> first_;                             // (N+1) row lengths at i + 1, summed by candidates()
  std::atomic<bool> image_overflow_{false};
};
void rebuild_pairs(const Model& model, State& state, PairSearch& search);

// The invariants the pair loop, the kick and the next build rely on, over a list of `particles`: CSR offsets from
// 0 to the pair count, every per-pair array of that length, each row's neighbours strictly increasing (the
// build's merge finds a persisting contact by j), a crossing pair's neighbour in a later force block, and the
// crossing arrays a CSR by j of exactly those pairs, in pair order. Aborts naming the broken one
// (core/check.hpp); rebuild_pairs calls it in the checking build, tests call it anywhere.
void check_pair_list(const PairList& pl, std::size_t particles);

// True when a pair outside the list could have come into contact since the last build, given the largest
// distance a particle has moved since then (drift_share() measures it on its way; largest_move_since_build()
// measures it on its own).
bool pairs_need_rebuild(const Model& model, const State& state, double largest_move);
bool pairs_need_rebuild(const Model& model, const State& state);  // measures the largest move itself
double largest_move_since_build(const State& state);  // [m]; infinity when the list was never built
// The largest |h (s_i - s_build_i)|^2 of particles [begin, end) of a built list [m^2]: the one definition of the
// move that both of the above measure (the drift block by block, right after moving it).
double largest_move2(const Mat3& h, const Particles& p, const PairList& pl, std::size_t begin, std::size_t end);

// Sets the skin of the next build (state.pairs.build_skin) from how long the current list lasted: scaled
// toward a lifetime of kSkinLifetime steps (at most halved or doubled at once), between kSmallestSkin of the
// deck's skin and the deck's skin. Call before a rebuild that pairs_need_rebuild asked for. A smaller skin
// lists fewer pairs apart and rebuilds more often; the best trade is a lifetime of some hundred steps, far
// shorter under a slow shear than the deck's skin gives, longer under a fast compression.
inline constexpr double kSkinLifetime = 150.0;  // [steps]
inline constexpr double kSmallestSkin = 1.0 / 32.0;
void adapt_skin(State& state);

// Replace the list with exactly the given contacts (history only), e.g. after reading a state file.
// The next rebuild_pairs() call merges them into the full list.
void set_stored_contacts(State& state, const std::vector<StoredContact>& contacts);

// The touching pairs with their history, in (i, j) order: what a state file keeps.
std::vector<StoredContact> stored_contacts(const State& state);

}  // namespace celldem
