// The time step: the whole algorithm on one screen.
#pragma once
#include <cstdint>
#include <functional>

#include "cell/control.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "integrate/leapfrog.hpp"

namespace celldem {

// What runs after each step, on one thread while the others wait (series rows, checks, the thread
// governor, which can only choose the team of the next call). rebuilt: whether the step rebuilt the
// neighbour list. Returns whether to go on in the same parallel region; it may set force_rebuild
// (advance_steps' argument) for the next step.
using AfterStep = std::function<bool(bool rebuilt)>;

// Advances the state step after step until after_step says stop, and the control's step counters with it.
// The threads stay in one parallel region from step to step and meet at spin barriers, so a step costs no
// fork and OpenMP's wait policy (PASSIVE puts waiting threads to sleep) matters only between calls; a
// change of thread count takes effect at the next call. force_rebuild rebuilds the neighbour list at the
// next step even if the skin would allow more steps (at the start of a segment and after checkpoints, so
// that a resumed run repeats the same arithmetic as an uninterrupted one); it is cleared when used. The
// arithmetic does not depend on the thread count. An exception from a step or from after_step ends the
// region and is rethrown. threads: the team size (0: OpenMP's default). Returns the number of steps done.
// The body damping's share of a step's energy budget: each force block's kick (KickDamping), added in block order.
void add_damping_to_energy_budget(const std::vector<KickDamping>& damping, EnergyLedger& energy);

std::int64_t advance_steps(const Model& model, const Loading& loading, State& state, bool& force_rebuild,
                           const AfterStep& after_step, int threads = 0);

// The forces of a state as it stands, nothing advanced (a stage's first row): a fresh neighbour list, the
// contact forces with this friction and no slip added, the net force and moment of every particle; with the
// model's energy budget, the budget opened at this state (measure/energy.hpp open_energy_budget).
void evaluate_forces(const Model& model, const Friction& friction, State& state);

}  // namespace celldem
