// Time integration (leapfrog, the same as velocity Verlet for positions): velocities live at half steps.
#pragma once
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Completes each particle's net contact force and moment (the pair loop summed the pairs where it is i;
// this adds those where it is j, in a fixed order).
void gather_forces(State& state);

// gather_forces, then advances the fluctuating velocity and the spin by one step with implicit body damping.
void gather_and_kick(const Model& model, State& state);

// Moves particles by their fluctuating velocity in scaled coordinates, s += dt h_mid^-1 v', where h_mid
// is the cell halfway between h_before and the current cell (the affine part is carried by the cell).
void drift(const Model& model, const Mat3& h_before, State& state);

}  // namespace celldem
