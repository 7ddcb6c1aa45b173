#include "step.hpp"

#include <omp.h>

#include <algorithm>
#include <exception>
#include <optional>
#include <vector>

#include "contact/contact_forces.hpp"
#include "core/parallel.hpp"
#include "integrate/leapfrog.hpp"
#include "neighbor/neighbor_list.hpp"

namespace celldem {

std::int64_t advance_steps(const Model& model, const Loading& loading, State& state, bool& force_rebuild,
                           const AfterStep& after_step, int threads) {
  std::int64_t steps = 0;
  std::exception_ptr failure;
  std::optional<SpinBarrier> barrier;
  std::vector<double> moved;  // per thread: the largest distance moved since the list was built [m]
  std::optional<PairSearch> search;
  std::optional<ContactForceEvaluation> forces;
  Mat3 h_before;
  bool rebuilt = false, go_on = true;
#pragma omp parallel num_threads(threads > 0 ? threads : omp_get_max_threads())
  {
    const int thread = omp_get_thread_num(), team = omp_get_num_threads();
#pragma omp single
    barrier.emplace(team), moved.assign(team, 0.0);
    // This thread's force blocks: its share of the pair loop, the drift and the kick, dealt anew at each rebuild.
    std::vector<std::size_t> my_blocks = thread_force_blocks(state.pairs, state.particles.size());
    // Runs f on one thread while the others wait; false once anything has failed (then every thread leaves).
    const auto one_thread = [&](auto&& f) {
      if (thread == 0 && !failure) {
        try {
          f();
        } catch (...) {
          failure = std::current_exception();
        }
      }
      barrier->wait();
      return !failure;
    };
    const BlocksDone kick_blocks = [&](std::size_t begin, std::size_t end) {
      gather_and_kick_range(model, state, begin, end);
    };

    while (go_on) {
      // 1. control: the cell at the end of the step
      if (!one_thread([&] { h_before = state.cell.h, advance_cell(model, loading, state); })) break;
      // 2. particles move by their fluctuating velocity
      moved[thread] = drift_share(model, h_before, state, my_blocks);
      barrier->wait();
      // 3. neighbours, with contact history carried over (the search shared among the threads)
      if (!one_thread([&] {
            const double largest = *std::max_element(moved.begin(), moved.end());
            const bool needed = pairs_need_rebuild(model, state, largest);
            rebuilt = force_rebuild || needed;
            force_rebuild = false;
            if (needed) adapt_skin(state);  // (not after a forced rebuild: the list had not run its course)
            if (rebuilt) search.emplace(model, state);
            else forces.emplace(model, loading.friction, state);
          }))
        break;
      if (rebuilt) {
        search->search_share();
        barrier->wait();
        if (!one_thread([&] {
              rebuild_pairs(model, state, *search), search.reset();
              forces.emplace(model, loading.friction, state);
            }))
          break;
        my_blocks = thread_force_blocks(state.pairs, state.particles.size());
      }
      // 4. contact forces and history; 5. net forces -> damped velocities and spins. On one thread each
      // block of particles is kicked as soon as its forces are complete (in cache); on more, each thread
      // kicks its share once all pairs are done.
      forces->evaluate_share(my_blocks, team == 1 ? kick_blocks : BlocksDone{});
      barrier->wait();
      if (team > 1) gather_and_kick_share(model, state, my_blocks);
      barrier->wait();
      // 6. stress and clocks, then whatever the caller does between steps
      if (!one_thread([&] {
            forces->finish();
            state.time += model.dt;
            ++state.steps_since_creation;
            ++state.control.stage_steps;  // (leg_steps: advance_cell)
            ++steps;
            go_on = after_step(rebuilt);
          }))
        break;
    }
  }
  if (failure) std::rethrow_exception(failure);
  return steps;
}

bool advance_one_step(const Model& model, const Loading& loading, State& state, bool force_rebuild) {
  bool rebuilt = false;
  advance_steps(model, loading, state, force_rebuild, [&](bool r) { return rebuilt = r, false; });
  return rebuilt;
}

void evaluate_forces(const Model& model, const Friction& friction, State& state) {
  rebuild_pairs(model, state);
  compute_contact_forces(model, friction, state, /*advance_slip=*/false);
  gather_forces(state);
}

}  // namespace celldem
