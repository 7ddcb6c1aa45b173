// Time integration (leapfrog, the same as velocity Verlet for positions): velocities live at half steps.
#pragma once
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Each particle's net contact force and moment, summed from the pair loop's per-pair forces and moments in one
// fixed order (PairList::incoming_pair), the same on any number of threads.
void gather_forces(State& state);

// What the body damping dissipated in one force block's kick [J] (the energy budget).
struct KickDamping {
  double translation = 0.0, rotation = 0.0;
};

// Sums the net force and moment of particles [begin, end) as gather_forces does, then advances their
// fluctuating velocity and spin by one step with implicit body damping (the kick), on the calling thread.
// damping: if given, set to what the damping dissipated in these particles, summed in particle order (the same
// velocities to the bit, one particle after the other instead of in SIMD lanes).
void gather_and_kick_range(const Model& model, State& state, std::size_t begin, std::size_t end,
                           KickDamping* damping = nullptr);

// The same for the given force blocks (the calling thread's: thread_force_blocks); called by every thread of a
// parallel region. damping: if given, one entry per force block of the particles, each block's set.
void gather_and_kick_share(const Model& model, State& state, const std::vector<std::size_t>& blocks,
                           std::vector<KickDamping>* damping = nullptr);

// Moves the particles of the given force blocks (the calling thread's: thread_force_blocks) by their
// fluctuating velocity in scaled coordinates, s += dt h_mid^-1 v', where h_mid is the cell halfway between
// h_before and the current cell (the affine part is carried by the cell). Returns, measured on the way, the
// largest distance [m] a particle of these blocks has moved since the neighbour list was built (for the
// rebuild criterion; infinity while it is not built).
double drift_share(const Model& model, const Mat3& h_before, State& state, const std::vector<std::size_t>& blocks);

}  // namespace celldem
