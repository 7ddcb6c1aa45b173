#include "step.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <optional>
#include <vector>

#include "contact/contact_forces.hpp"
#include "core/check.hpp"
#include "core/parallel.hpp"
#include "integrate/leapfrog.hpp"
#include "measure/energy.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {

namespace {

// What the threads of advance_steps hand each other from stage to stage: written on one thread (moved: each
// thread its own entry), read by the others after a barrier.
struct StepShared {
  Mat3 h_before;                                 // the cell at the start of the step
  std::vector<double> moved;                     // per thread: the largest distance moved since the list was built [m]
  std::optional<PairSearch> search;              // a rebuild's search, shared among the threads
  std::optional<ContactForceEvaluation> forces;  // the step's pair loop
  bool rebuilt = false;                          // whether this step rebuilt the neighbour list
  bool go_on = true;                             // after_step's answer
  std::int64_t steps = 0;
  // The energy budget (Model::energy_budget): what the body damping dissipated in each force block's kick this
  // step, added to the budget in block order (the same sum for any thread count).
  std::vector<KickDamping> damping;
  // For the checking build (core/check.hpp) only: each thread's force blocks as last dealt, and how many
  // threads have done their share of this step's pair loop.
  std::vector<std::vector<std::size_t>> dealt;
  std::atomic<int> pair_loop_shares_done{0};
};

// One thread's part of the steps: the six stages, each on every thread of the team (its force blocks) or
// on one thread while the others wait (Team::Member::serial). A stage that returns false ends the region.
class StepThread {
 public:
  StepThread(const Model& model, const Loading& loading, State& state, bool& force_rebuild, const AfterStep& after_step,
             StepShared& shared, Team::Member team)
      : model_(model),
        loading_(loading),
        state_(state),
        force_rebuild_(force_rebuild),
        after_step_(after_step),
        shared_(shared),
        team_(team),
        kick_blocks_([&model, &state, &shared](std::size_t begin, std::size_t end) {
          gather_and_kick_range(model, state, begin, end,
                                model.energy_budget ? &shared.damping[begin / kForceBlock] : nullptr);
        }) {
    deal_force_blocks();
  }

  bool step() {
    if (!control()) return false;
    drift();
    if (!neighbours()) return false;
    contact_forces();
    kick();
    return end_step();
  }

 private:
  // 1. control: the cell at the end of the step (one thread)
  bool control() {
    return team_.serial([&] {
      shared_.h_before = state_.cell.h, advance_cell(model_, loading_, state_);
      // Not the determinant: a strain-driven leg the deck ends by its steps may drive an axis through zero.
      CELLDEM_ASSERT(!shared_.h_before.allFinite() || !state_.stress.allFinite() || state_.cell.h.allFinite(),
                     "the control step keeps a finite cell finite while the stresses it follows are finite");
    });
  }

  // 2. particles move by their fluctuating velocity, measuring how far they moved since the list was built
  void drift() {
    shared_.moved[team_.thread()] = drift_share(model_, shared_.h_before, state_, blocks_);
    team_.wait();
  }

  // 3. neighbours, if the list is due (or force_rebuild), with contact history carried over: the search
  // shared among the threads, the rest on one thread, which then sets up the pair loop; the force blocks
  // dealt anew
  bool neighbours() {
    if (!team_.serial([&] {
          const double largest = *std::max_element(shared_.moved.begin(), shared_.moved.end());
          const bool needed = pairs_need_rebuild(model_, state_, largest);
          shared_.rebuilt = force_rebuild_ || needed;
          force_rebuild_ = false;
          if (needed) adapt_skin(state_);  // (not after a forced rebuild: the list had not run its course)
          if (shared_.rebuilt) shared_.search.emplace(model_, state_);
          else shared_.forces.emplace(model_, loading_.friction, state_, /*advance_slip=*/true, needs_shear_sums(loading_));
          shared_.pair_loop_shares_done.store(0, std::memory_order_relaxed);  // (the serial section's barrier orders it)
        }))
      return false;
    if (!shared_.rebuilt) return true;
    shared_.search->search_share();
    team_.wait();
    if (!team_.serial([&] {
          rebuild_pairs(model_, state_, *shared_.search), shared_.search.reset();
          shared_.forces.emplace(model_, loading_.friction, state_, /*advance_slip=*/true, needs_shear_sums(loading_));
        }))
      return false;
    deal_force_blocks();
    return true;
  }

  // 4. contact forces and history. On one thread each block of particles is also kicked (stage 5) as soon
  // as its forces are complete, while in cache.
  void contact_forces() {
    shared_.forces->evaluate_share(blocks_, team_.size() == 1 ? kick_blocks_ : BlocksDone{});
    if constexpr (kCheckInvariants) shared_.pair_loop_shares_done.fetch_add(1, std::memory_order_relaxed);
    team_.wait();
  }

  // 5. net forces -> damped velocities and spins, each thread its force blocks once all pairs are done
  void kick() {
    CELLDEM_ASSERT(shared_.pair_loop_shares_done.load(std::memory_order_relaxed) == team_.size(),
                   "every thread has done its share of the step's pair loop before any thread kicks");
    if (team_.size() > 1)
      gather_and_kick_share(model_, state_, blocks_, model_.energy_budget ? &shared_.damping : nullptr);
    team_.wait();
  }

  // 6. stress and clocks, then whatever the caller does between steps (one thread)
  bool end_step() {
    return team_.serial([&] {
      shared_.forces->finish();
      if (model_.energy_budget) add_damping_to_energy_budget(shared_.damping, state_.energy);
      state_.time += model_.dt;
      ++state_.steps_since_creation;
      ++state_.control.stage_steps;  // (leg_steps: advance_cell)
      ++shared_.steps;
      shared_.go_on = after_step_(shared_.rebuilt);
    }) && shared_.go_on;
  }

  // This thread's force blocks, dealt anew whenever the list changes; in the checking build, every thread's
  // deal is checked to be a partition of the blocks.
  void deal_force_blocks() {
    blocks_ = thread_force_blocks(state_.pairs, state_.particles.size());
    if constexpr (kCheckInvariants) {
      shared_.dealt[static_cast<std::size_t>(team_.thread())] = blocks_;
      team_.wait();
      team_.serial([&] { check_force_block_partition(shared_.dealt, state_.particles.size()); });
    }
  }

  const Model& model_;
  const Loading& loading_;
  State& state_;
  bool& force_rebuild_;
  const AfterStep& after_step_;
  StepShared& shared_;
  Team::Member team_;
  std::vector<std::size_t> blocks_;  // this thread's force blocks (thread_force_blocks), for stages 2, 4 and 5
  const BlocksDone kick_blocks_;     // stage 5 for one force block
};

}  // namespace

void add_damping_to_energy_budget(const std::vector<KickDamping>& damping, EnergyLedger& energy) {
  for (const KickDamping& block : damping) {
    energy.damping_translation += block.translation;
    energy.damping_rotation += block.rotation;
  }
}

std::int64_t advance_steps(const Model& model, const Loading& loading, State& state, bool& force_rebuild,
                           const AfterStep& after_step, int threads) {
  const int team_size = threads > 0 ? threads : omp_get_max_threads();
  StepShared shared;
  shared.moved.assign(team_size, 0.0);  // (a smaller team leaves the rest at zero)
  shared.dealt.resize(static_cast<std::size_t>(team_size));  // (and its deal empty)
  if (model.energy_budget) shared.damping.resize((state.particles.size() + kForceBlock - 1) / kForceBlock);
  Team team;
#pragma omp parallel num_threads(team_size)
  {
    StepThread thread(model, loading, state, force_rebuild, after_step, shared, team.join());
    while (thread.step()) {
    }
  }
  team.rethrow();
  return shared.steps;
}

void evaluate_forces(const Model& model, const Friction& friction, State& state) {
  rebuild_pairs(model, state);
  compute_contact_forces(model, friction, state, /*advance_slip=*/false);
  gather_forces(state);
  if (model.energy_budget) open_energy_budget(model, state);
}

}  // namespace celldem
