// Time integration (leapfrog, the same as velocity Verlet for positions): velocities live at half steps.
#pragma once
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Completes each particle's net contact force and moment (the pair loop summed the pairs within its force
// block; this adds those that cross into it from other blocks, in a fixed order).
void gather_forces(State& state);

// Split among the threads: completes each particle's net force and moment as gather_forces does, then
// advances its fluctuating velocity and spin by one step with implicit body damping.
void gather_and_kick(const Model& model, State& state);

// The same for particles [begin, end), on the calling thread.
void gather_and_kick_range(const Model& model, State& state, std::size_t begin, std::size_t end);

// The same for the given force blocks (the calling thread's: thread_force_blocks); called by every thread of a
// parallel region.
void gather_and_kick_share(const Model& model, State& state, const std::vector<std::size_t>& blocks);

// Moves particles by their fluctuating velocity in scaled coordinates, s += dt h_mid^-1 v', where h_mid
// is the cell halfway between h_before and the current cell (the affine part is carried by the cell).
// Returns, measured on the way, the largest distance [m] a particle has moved since the neighbour list was
// built (largest_move_since_build(), for the rebuild criterion).
double drift(const Model& model, const Mat3& h_before, State& state);

// The same for the given force blocks (the calling thread's: thread_force_blocks), inside a parallel region;
// returns the largest distance moved in them.
double drift_share(const Model& model, const Mat3& h_before, State& state, const std::vector<std::size_t>& blocks);

}  // namespace celldem
