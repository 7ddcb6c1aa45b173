// The pair loop: every listed pair through the contact law, its history updated, and the reductions the
// control needs (stress, axis stiffness, contact count).
#pragma once
#include <functional>

#include "contact/contact_law.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Evaluates all pairs at the current positions with the half-step velocities, stores per-pair forces and
// moments and the new history, and sets state.normal_stress, state.axis_stiffness and state.touching.
// With advance_slip = false no slip is added (the forces of the state as it stands, e.g. at a stage start).
//
// What may follow inside the loop's parallel region, while the data are in cache and without another fork:
// on one thread, blocks_done(begin, end) after each block of owners (every pair of the particles in
// [begin, end) has then been evaluated: a pair's owner has the lower id, so their net forces can be
// completed; later pairs never read them again); on more threads, share_done() by every thread once all
// pairs are evaluated (after a barrier). Returns how many particles, from the first, were handed over.
struct Handover {
  std::function<void(std::size_t begin, std::size_t end)> blocks_done;  // one thread
  std::function<void()> share_done;                                     // more threads: this thread's share
};
std::size_t compute_contact_forces(const Model& model, const Friction& friction, State& state, bool advance_slip = true,
                                   const Handover& handover = {});

// The full contact stress tensor [Pa] (symmetric part, compression positive) of the last force
// evaluation, sum of force (x) branch over the contacts divided by the cell volume. The step keeps only
// its diagonal (state.normal_stress: all that the control needs); this sums the same terms in the same
// order, so its diagonal is the same to the bit.
Mat3 contact_stress(const State& state);

}  // namespace celldem
