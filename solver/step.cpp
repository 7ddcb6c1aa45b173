#include "step.hpp"

#include "contact/contact_forces.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {

bool advance_one_step(const Model& model, const Loading& loading, State& state, bool force_rebuild) {
  const Mat3 h_before = state.cell.h;
  advance_cell(model, loading, state);                 // 1. control: the cell at the end of the step
  const double moved = drift(model, h_before, state);  // 2. particles move by their fluctuating velocity
  const bool rebuild = force_rebuild || pairs_need_rebuild(model, state, moved);
  if (rebuild) rebuild_pairs(model, state);            // 3. neighbours, with contact history carried over
  // 4. contact forces, history, stress; 5. net forces -> damped velocities and spins, inside the pair loop's
  // parallel region: on one thread each block of particles as soon as its forces are complete (in cache), on
  // more each thread its share once all pairs are done. Whatever was not handed over is kicked after.
  const Handover kick{[&](std::size_t begin, std::size_t end) { gather_and_kick_range(model, state, begin, end); },
                      [&] { gather_and_kick_share(model, state); }};
  const std::size_t kicked = compute_contact_forces(model, loading.friction, state, true, kick);
  gather_and_kick(model, state, kicked);
  state.time += model.dt;
  ++state.steps_since_creation;
  ++state.control.stage_steps;  // (phase_steps: advance_cell)
  return rebuild;
}

void evaluate_forces(const Model& model, const Friction& friction, State& state) {
  rebuild_pairs(model, state);
  compute_contact_forces(model, friction, state, /*advance_slip=*/false);
  gather_forces(state);
}

}  // namespace celldem
