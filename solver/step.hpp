// The time step: the whole algorithm on one screen.
#pragma once
#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Advances the state by one time step under the given loading, and the control's step counters by one.
// force_rebuild rebuilds the neighbour list even if the skin would allow more steps (at the start of a
// segment and after checkpoints, so that a resumed run repeats the same arithmetic as an uninterrupted
// one). Returns whether the list was rebuilt.
bool advance_one_step(const Model& model, const Loading& loading, State& state, bool force_rebuild = false);

// The forces of a state as it stands, nothing advanced (a stage's first row): a fresh neighbour list, the
// contact forces with this friction and no slip added, the net force and moment of every particle.
void evaluate_forces(const Model& model, const Friction& friction, State& state);

}  // namespace celldem
