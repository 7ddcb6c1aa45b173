// The pair loop: every listed pair through the contact law, its history updated, its force and moments on both
// ends, and the sums the control needs (stress, axis stiffness, contact count). Each particle's net force and
// moment are summed from its pairs afterwards, by the kick (integrate/leapfrog.cpp gather_forces). The same loop
// written plainly, for reading and for the tests: contact_forces_reference.hpp.
//
// A map of contact_forces.cpp.
// Two kinds of block, both of consecutive particle ids (a pair belongs to its owner, the lower id):
// - force blocks (kForceBlock, 2048 ids, core/state.hpp): what a thread takes (thread_force_blocks; the drift
//   and the kick take the same). Once a block's pairs are evaluated, its particles' net forces can be summed:
//   the pairs that reach into a block are owned by it or by earlier blocks (PairList::incoming_pair).
// - reduction blocks (kReductionBlock, 256 owners, eight to a force block): the unit of the cell's sums.
//   Each sums its owners' pairs in list order (ReductionSums); finish() adds the blocks in order.
// Either way every sum runs in one fixed order, whatever the number of threads.
// Four kernels, per chunk of up to 64 pairs (kChunk) of one reduction block, called by evaluate_share:
// - chunk_owners: each pair's owner, from the list's offsets (the list stores none per pair);
// - gather_chunk (gather_chunk_avx2 where the CPU has AVX2, the same bits): both ends' positions,
//   velocities, spins and radii, component-major, one lane per pair;
// - evaluate_chunk: the contact law (contact_law.hpp) in SIMD lanes (target_clones: AVX-512, AVX2 or
//   SSE2, the same bits); writes each pair's force, moments and springs in place;
// - sum_chunk: in pair order, adds each pair to the reduction block's sums and stores its flags.
#pragma once
#include <functional>
#include <vector>

#include "contact/contact_law.hpp"
#include "core/model.hpp"
#include "core/state.hpp"

namespace celldem {

// Evaluates all pairs at the current positions with the half-step velocities, stores per-pair forces and
// moments and the new history, and sets state.stress and state.stiffness (the six components: s11 s22 s33 s12
// s13 s23; the shear ones zero unless shear_sums) and state.touching.
// With advance_slip = false no slip is added (the forces of the state as it stands, e.g. at a stage start).
void compute_contact_forces(const Model& model, const Friction& friction, State& state, bool advance_slip = true);

// The same evaluation inside a parallel region the caller owns (the time step's, which spans many steps):
// every thread calls evaluate_share() once with its force blocks (thread_force_blocks), then one thread calls
// finish() once all have returned.
// blocks_done(begin, end), if given, is called after each force block: every pair owned by the
// particles in [begin, end) has then been evaluated by this thread. On one thread their net forces can then
// be completed while in cache: the pairs that cross into a block are owned by earlier blocks (a pair's
// owner has the lower id), and later pairs never touch the block's sums again.
using BlocksDone = std::function<void(std::size_t begin, std::size_t end)>;
// Owners per reduction block. Only touching pairs add to the sums (the others add exact zeros), so they
// depend neither on the thread count nor on which pairs apart the neighbour list holds (a rebuild never
// changes the arithmetic).
constexpr std::size_t kReductionBlock = 256;
static_assert(kForceBlock % kReductionBlock == 0, "force blocks are made of whole reduction blocks");
struct ReductionSums {                // one reduction block's sums over its owners' pairs, in list order
  Vec3 normal_sum = Vec3::Zero();     // sum of force_k branch_k [N m]
  Vec3 stiffness_sum = Vec3::Zero();  // sum of kn (n_k l_k)^2 [N m]
  Vec3 shear_sum = Vec3::Zero();      // sum of (force_i branch_j + force_j branch_i) / 2, ij = 12, 13, 23 [N m]
  Vec3 shear_stiffness_sum = Vec3::Zero();  // sum of kn (n_i l_j)^2 [N m] (cell/control.hpp: why)
  Vec3 spin_sum = Vec3::Zero();     // sum of (force_i branch_j - force_j branch_i) / 2, ij = 12, 13, 23 [N m] (energy)
  Vec3 dissipation = Vec3::Zero();  // [J] at the Coulomb caps, the rolling and twisting caps, the dashpot (energy)
  std::int64_t touching = 0;
};
class ContactForceEvaluation {
 public:
  // shear_sums: also sum the shear components of state.stress and state.stiffness (else they are set to zero); a loading with a
  // shear servo needs them (cell/control.hpp needs_shear_sums), and a stage's first evaluation makes them.
  ContactForceEvaluation(const Model& model, const Friction& friction, State& state, bool advance_slip = true,
                         bool shear_sums = true);
  void evaluate_share(const std::vector<std::size_t>& blocks, const BlocksDone& blocks_done = {});
  // The reductions, summed block by block in order: the same for any thread count. With the model's energy
  // budget (Model::energy_budget), the step's terms are added to state.energy too.
  void finish();

  using ShareFn = void (*)(const ContactParams&, State&, double, std::vector<ReductionSums>&,
                           const std::vector<std::size_t>&, const BlocksDone&);

 private:
  ContactParams params_;
  State& state_;
  void add_to_energy_budget(const ReductionSums& total);
  double dt_;
  bool energy_;
  std::vector<ReductionSums> reduction_sums_;  // (reduction blocks)
  ShareFn share_;
};

// The pair loop gathers each chunk's particle data with AVX2 where the CPU has it, else with portable code;
// both give the same bits. use_portable_gather(true) makes every later evaluation use the portable code
// (for tests that compare the two). Only tests call these, but they stay here: the switch is the pair loop's
// own dispatch, which nothing outside this module can reach.
bool vector_gather_available();
void use_portable_gather(bool portable);

// The sum that defines the contact stress, force (x) branch over the listed pairs, in the pair loop's
// order and arithmetic: each reduction block of owners (kReductionBlock ids) summed in list order, then the
// blocks in order, the branch h ds summed left to right (Eigen's h * ds sums its third row in another
// order), so that its diagonal is state.normal_stress's sum to the bit. Pairs apart hold zero force and add
// nothing. add() takes the pairs in list order (for_each_pair), each with its owner. measure_contacts
// (measure/micro.hpp) sums a row's stress with it.
class ContactStressSum {
 public:
  explicit ContactStressSum(const Mat3& h) : h_(h) {}
  // ds: the pair's scaled separation s_j - s_i + image.
  void add(Index owner, const Vec3& force, const Vec3& ds);
  // [Pa] the symmetric part over the cell volume, compression positive.
  Mat3 stress(double volume) const;

 private:
  Mat3 h_;                         // [m] the cell
  std::size_t block_ = 0;          // the reduction block being summed
  Mat3 block_sum_ = Mat3::Zero();  // [N m] its sum so far
  Mat3 total_ = Mat3::Zero();      // [N m] the blocks before it
};

}  // namespace celldem
