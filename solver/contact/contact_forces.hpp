// The pair loop: every listed pair through the contact law, its history updated, and the reductions the
// control needs (stress, axis stiffness, contact count).
#pragma once
#include "contact/linear_spring.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Evaluates all pairs at the current positions with the half-step velocities, stores per-pair forces and
// moments and the new history, and sets state.normal_stress, state.axis_stiffness and state.touching.
// With advance_slip = false no slip is added (the forces of the state as it stands, e.g. at a stage start).
void compute_contact_forces(const Model& model, double friction, State& state, bool advance_slip = true);

// The full contact stress tensor [Pa] (symmetric part, compression positive) of the last force
// evaluation, sum of force (x) branch over the contacts divided by the cell volume. The step keeps only
// its diagonal (state.normal_stress: all that the control needs); this sums the same terms in the same
// order, so its diagonal is the same to the bit.
Mat3 contact_stress(const State& state);

}  // namespace celldem
