// Everything that can be checked before a run does any work, beyond what the deck reader checks on its own:
// the cell large enough for its particles, the initial state readable and agreeing with the deck's sample,
// the time step against the lightest particle actually present and not so small that the run cannot end.
// `celldem check` and `celldem run` both call it, so check passes exactly what run accepts.
#pragma once
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"

namespace celldem {

// Below this fraction of sqrt(m_min/kn) a time step is refused: the run would take a thousand times the
// steps it needs (a typo such as 1e-300 would otherwise spin for ever).
inline constexpr double kMinTimeStepFraction = 1e-3;
// Below this fraction it is warned about.
inline constexpr double kSlowTimeStepFraction = 0.02;

// Throws DeckError (or StateFileError for an unreadable state) naming the key and both values; returns the
// warnings (printed by the caller, recorded in the summary by a run).
std::vector<std::string> preflight(const Deck& deck);

// The deck's initial_state, resolved against the deck's folder.
std::string initial_state_path(const Deck& deck);

// The sample the deck's tests start from: a celldem state file, or a LAMMPS data file (atom_style sphere,
// orthogonal box) whose one density must equal sample.density (DeckError naming both otherwise). A data file
// carries no contact history: the tests start with untouched tangential springs.
State load_initial_state(const Deck& deck);

}  // namespace celldem
