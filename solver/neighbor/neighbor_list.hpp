// Half neighbour list with periodic images, built in the cell's scaled coordinates with a skin, and the
// criterion that says when it must be rebuilt (particle motion and cell deformation together).
#pragma once
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Rebuilds state.pairs for the current positions: lists every pair closer than r_i + r_j + skin and
// carries over the contact history of pairs that persist.
// Throws std::runtime_error if the cell has become too small for its particles (a pair would touch twice).
void rebuild_pairs(const Model& model, State& state);

// True when a pair outside the list could have come into contact since the last build, given the largest
// distance a particle has moved since then (drift() measures it on its way; largest_move_since_build()
// measures it on its own).
bool pairs_need_rebuild(const Model& model, const State& state, double largest_move);

// Sets the skin of the next build (state.pairs.build_skin) from how long the current list lasted: scaled
// toward a lifetime of kSkinLifetime steps (at most halved or doubled at once), between kSmallestSkin of the
// deck's skin and the deck's skin. Call before a rebuild that pairs_need_rebuild asked for. A smaller skin
// lists fewer pairs apart and rebuilds more often; the best trade is a lifetime of some hundred steps, far
// shorter under a slow shear than the deck's skin gives, longer under a fast compression.
inline constexpr double kSkinLifetime = 150.0;  // [steps]
inline constexpr double kSmallestSkin = 1.0 / 32.0;
void adapt_skin(State& state);
bool pairs_need_rebuild(const Model& model, const State& state);
double largest_move_since_build(const State& state);  // [m]; infinity when the list was never built

// Replace the list with exactly the given contacts (history only), e.g. after reading a state file.
// The next rebuild_pairs() call merges them into the full list.
void set_stored_contacts(State& state, const std::vector<StoredContact>& contacts);

// The touching pairs with their history, in (i, j) order: what a state file keeps.
std::vector<StoredContact> stored_contacts(const State& state);

}  // namespace celldem
