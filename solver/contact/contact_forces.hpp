// The pair loop: every listed pair through the contact law, its history updated, and the reductions the
// control needs (stress, axis stiffness, contact count).
#pragma once
#include <functional>
#include <vector>

#include "contact/contact_law.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Evaluates all pairs at the current positions with the half-step velocities, stores per-pair forces and
// moments and the new history, and sets state.normal_stress, state.axis_stiffness and state.touching.
// With advance_slip = false no slip is added (the forces of the state as it stands, e.g. at a stage start).
void compute_contact_forces(const Model& model, const Friction& friction, State& state, bool advance_slip = true);

// The same evaluation inside a parallel region the caller owns (the time step's, which spans many steps):
// every thread calls evaluate_share() once with its force blocks (thread_force_blocks), then one thread calls
// finish() once all have returned.
// blocks_done(begin, end), if given, is called after each force block (kForceBlock): every pair owned by the
// particles in [begin, end) has then been evaluated by this thread. On one thread their net forces can then
// be completed while in cache: the pairs that cross into a block are owned by earlier blocks (a pair's
// owner has the lower id), and later pairs never touch the block's sums again.
using BlocksDone = std::function<void(std::size_t begin, std::size_t end)>;
struct ContactBlockSums {             // one block of owners' share of the reductions
  Vec3 normal_sum = Vec3::Zero();     // sum of force_k branch_k [N m]
  Vec3 stiffness_sum = Vec3::Zero();  // sum of kn (n_k l_k)^2 [N m]
  std::int64_t touching = 0;
};
class ContactForceEvaluation {
 public:
  ContactForceEvaluation(const Model& model, const Friction& friction, State& state, bool advance_slip = true);
  void evaluate_share(const std::vector<std::size_t>& blocks, const BlocksDone& blocks_done = {});
  void finish();  // the reductions, summed block by block in order: the same for any thread count

  using ShareFn = void (*)(const ContactParams&, State&, double, std::vector<ContactBlockSums>&,
                           const std::vector<std::size_t>&, const BlocksDone&);

 private:
  ContactParams params_;
  State& state_;
  double dt_;
  std::vector<ContactBlockSums> partial_;
  ShareFn share_;
};

// The pair loop gathers each chunk's particle data with AVX2 where the CPU has it, else with portable code;
// both give the same bits. use_portable_gather(true) makes every later evaluation use the portable code
// (for tests that compare the two).
bool vector_gather_available();
void use_portable_gather(bool portable);

// The full contact stress tensor [Pa] (symmetric part, compression positive) of the last force
// evaluation, sum of force (x) branch over the contacts divided by the cell volume. The step keeps only
// its diagonal (state.normal_stress: all that the control needs); this sums the same terms in the same
// order, so its diagonal is the same to the bit.
Mat3 contact_stress(const State& state);

}  // namespace celldem
