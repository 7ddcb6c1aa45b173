// The step's parts as whole-state calls, for tests that drive one stage or one step at a time. The solver
// runs them only inside advance_steps' parallel region (solver/step.cpp), by force block; these are the
// same functions on every thread of a region of their own.
#pragma once
#include <omp.h>

#include <algorithm>

#include "core/model.hpp"
#include "core/state.hpp"
#include "integrate/leapfrog.hpp"
#include "step.hpp"

namespace celldem::testing {

// One step (advance_steps for one step). Returns whether the list was rebuilt.
inline bool advance_one_step(const Model& model, const Loading& loading, State& state, bool force_rebuild = false) {
  bool rebuilt = false;
  advance_steps(model, loading, state, force_rebuild, [&](bool r) { return rebuilt = r, false; });
  return rebuilt;
}

// Stage 2 on its own: moves particles by their fluctuating velocity, s += dt h_mid^-1 v', h_mid halfway
// between h_before and the current cell. Returns the largest distance [m] a particle has moved since the
// neighbour list was built (infinity while it is not built).
inline double drift(const Model& model, const Mat3& h_before, State& state) {
  double largest = 0.0;  // a maximum: the same whatever the order
#pragma omp parallel reduction(max : largest)
  largest = std::max(largest, drift_share(model, h_before, state, thread_force_blocks(state.pairs, state.particles.size())));
  return largest;
}

// Stage 5 on its own: completes each particle's net force and moment as gather_forces does, then advances
// its fluctuating velocity and spin by one step with implicit body damping.
inline void gather_and_kick(const Model& model, State& state) {
#pragma omp parallel
  gather_and_kick_share(model, state, thread_force_blocks(state.pairs, state.particles.size()));
}

}  // namespace celldem::testing
