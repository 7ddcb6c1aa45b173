// The sample a deck starts from when it names one (initial_state): a celldem state file or a LAMMPS data file,
// loaded and checked against the deck's density; and the physics record a state file keeps of the deck it was
// made with.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "core/deck.hpp"
#include "core/state.hpp"

namespace celldem {

// The deck's initial_state, resolved against the deck's folder.
std::string initial_state_path(const Deck& deck);

// The sample the deck's tests start from: a celldem state file, or a LAMMPS data file (atom_style sphere,
// orthogonal box) whose one density must equal sample.density (DeckError naming both otherwise). A data file
// carries no contact history: the tests start with untouched tangential springs.
struct InitialSample {
  State state;
  std::vector<std::int64_t> atom_ids;  // (N) a LAMMPS data file's atom ids; empty for a state file
  std::string physics;                 // a state file's physics record (state_physics); may be empty
  bool state_file = false;             // a celldem state file (else a LAMMPS data file)
};
InitialSample load_initial_sample(const Deck& deck);
State load_initial_state(const Deck& deck);  // load_initial_sample(deck).state

// What a state file records of the physics it was made with: the density and the contact law with its
// parameters, as JSON text keyed by deck key path. A deck that starts from the state must agree with it.
std::string state_physics(const Deck& deck);

}  // namespace celldem
