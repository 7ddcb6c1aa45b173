// The step loop (solver/step.cpp, advance_steps): many steps in one parallel region give the same bits as
// one step at a time, on any thread count and however the run is cut into regions; an exception from
// between the steps ends the region and reaches the caller; the spin barrier it relies on orders every
// thread's writes before the others' reads; the check of the force blocks' deal catches a broken one.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "core/parallel.hpp"
#include "helpers.hpp"
#include "step.hpp"

namespace celldem {
namespace {

constexpr int kSteps = 60;

// Jostled spheres under an axial strain: the cell moves, contacts form, slide and part, and the list is
// rebuilt now and then.
struct Scene {
  Model model;
  Loading loading;
  State state;
};
Scene scene() {
  State s = testing::jostled_lattice(6, 7, 0.02, 0.5, 0.5);
  const Deck deck = testing::model_deck(1e4, 1e4, 1e-3, testing::kUnitMassDensity, 0.1, 0.1);
  const AxisControl fixed{AxisMode::StrainIncrement, 0.0};
  const Loading loading{{AxisControl{AxisMode::StrainIncrement, 5e-4}, fixed, fixed}, 0.3};
  return {make_model(deck, s.particles.radius), loading, std::move(s)};
}

void expect_same_bits(const State& a, const State& b) {
  ASSERT_EQ(a.particles.size(), b.particles.size());
  EXPECT_EQ(a.cell.h, b.cell.h);
  EXPECT_EQ(a.stress.head<3>(), b.stress.head<3>());
  EXPECT_EQ(a.touching, b.touching);
  EXPECT_EQ(a.control.stage_steps, b.control.stage_steps);
  EXPECT_EQ(a.time, b.time);
  for (std::size_t i = 0; i < a.particles.size(); ++i) {
    EXPECT_EQ(a.particles.scaled[i], b.particles.scaled[i]) << i;
    EXPECT_EQ(a.particles.velocity[i], b.particles.velocity[i]) << i;
    EXPECT_EQ(a.particles.spin[i], b.particles.spin[i]) << i;
  }
  ASSERT_EQ(a.pairs.size(), b.pairs.size());
  for (std::size_t q = 0; q < a.pairs.size(); ++q) EXPECT_EQ(a.pairs.tangential[q], b.pairs.tangential[q]) << q;
}

TEST(StepLoop, ManyStepsInOneRegionEqualOneStepAtATime) {
  Scene one_at_a_time = scene();
  int rebuilds = 0;
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  for (int k = 0; k < kSteps; ++k)
    rebuilds += testing::advance_one_step(one_at_a_time.model, one_at_a_time.loading, one_at_a_time.state, k == 0);
  omp_set_num_threads(saved);
  ASSERT_GT(one_at_a_time.state.touching, 0);
  ASSERT_GT(rebuilds, 1);  // the list was rebuilt on the way, not only at the start

  for (int threads : {1, 2, 3}) {
    Scene s = scene();
    bool rebuild = true;
    int done = 0;
    while (done < kSteps)
      advance_steps(s.model, s.loading, s.state, rebuild, [&](bool) { return ++done < kSteps; }, threads);
    SCOPED_TRACE(threads);
    expect_same_bits(one_at_a_time.state, s.state);
  }
  // Cut into regions of 7 steps with the team changing between them, as the thread governor does.
  Scene s = scene();
  bool rebuild = true;
  int done = 0;
  for (int region = 0; done < kSteps; ++region)
    advance_steps(s.model, s.loading, s.state, rebuild, [&](bool) { return ++done % 7 != 0 && done < kSteps; },
                  1 + region % 3);
  expect_same_bits(one_at_a_time.state, s.state);
}

TEST(StepLoop, AnExceptionBetweenStepsEndsTheRegionAndReachesTheCaller) {
  for (int threads : {1, 2}) {
    Scene s = scene();
    bool rebuild = true;
    int done = 0;
    EXPECT_THROW(advance_steps(s.model, s.loading, s.state, rebuild,
                               [&](bool) -> bool {
                                 if (++done == 5) throw std::runtime_error("stop");
                                 return true;
                               },
                               threads),
                 std::runtime_error);
    EXPECT_EQ(s.state.control.stage_steps, 5);  // no step after the one that threw
  }
}

// Serial sections back to back, with no barrier between them: thread 0 throws in the 200th while its
// partner may still be reading the outcome of the 199th. Every thread leaves after the same section (none
// waits at a barrier the others have left) and the exception reaches the caller.
TEST(Team, EveryThreadLeavesAfterTheSectionThatThrew) {
  constexpr int kThreads = 3, kFailAt = 200;
  for (int round = 0; round < 20; ++round) {
    Team team;
    int left_after[kThreads] = {};
    int calls = 0, size = 0;
#pragma omp parallel num_threads(kThreads)
    {
      Team::Member me = team.join();
      if (me.thread() == 0) size = me.size();
      int sections = 0;
      while (++sections, me.serial([&] {
        if (++calls == kFailAt) throw std::runtime_error("section 200");
      })) {
      }
      left_after[me.thread()] = sections;
    }
    EXPECT_THROW(team.rethrow(), std::runtime_error);
    EXPECT_EQ(calls, kFailAt);
    for (int t = 0; t < size; ++t) EXPECT_EQ(left_after[t], kFailAt);
  }
}

TEST(SpinBarrier, EveryThreadSeesTheOthersWritesOfThePhase) {
  constexpr int kThreads = 3, kRounds = 300;
  SpinBarrier barrier(kThreads);
  int slot[kThreads] = {};
  int wrong = 0;
#pragma omp parallel num_threads(kThreads) reduction(+ : wrong)
  {
    const int t = omp_get_thread_num();
    if (omp_get_num_threads() == kThreads)
      for (int round = 1; round <= kRounds; ++round) {
        slot[t] = round;
        barrier.wait();
        for (int u = 0; u < kThreads; ++u) wrong += slot[u] != round;
        barrier.wait();  // nobody writes the next round before all have read this one
      }
  }
  EXPECT_EQ(wrong, 0);
}

// Every block goes to exactly one thread, in ascending order within a thread. Four blocks of the paper
// sample's pair counts on two threads are dealt {0, 3} and {1, 2} (the best split: 13 128 and 13 804 pairs;
// contiguous runs can do no better than 14 488 and 12 444); many blocks go out as contiguous runs.
TEST(ThreadBlocks, EachBlockToOneThreadAndFewBlocksBalanced) {
  const auto deal = [](const std::vector<std::size_t>& before, int threads) {
    std::vector<std::vector<std::size_t>> dealt(threads);
#pragma omp parallel num_threads(threads)
    if (omp_get_num_threads() == threads)
      dealt[omp_get_thread_num()] =
          thread_blocks(before.size() - 1, [&](std::size_t b) { return before[b]; });
    return dealt;
  };
  const std::vector<std::size_t> paper = {0, 7598, 14488, 21402, 26932};  // pairs before each block
  const auto two = deal(paper, 2);
  EXPECT_EQ(two[0], (std::vector<std::size_t>{0, 3}));
  EXPECT_EQ(two[1], (std::vector<std::size_t>{1, 2}));

  std::vector<std::size_t> many(41);
  for (std::size_t b = 1; b < many.size(); ++b) many[b] = many[b - 1] + 100 + 37 * (b % 5);
  for (const auto& before : {paper, many})
    for (int threads : {1, 2, 3, 5}) {
      SCOPED_TRACE(threads);
      std::vector<int> seen(before.size() - 1, 0);
      for (const auto& mine : deal(before, threads)) {
        EXPECT_TRUE(std::is_sorted(mine.begin(), mine.end()));
        for (std::size_t b : mine) ++seen[b];
      }
      for (int c : seen) EXPECT_EQ(c, 1);
    }
  const auto runs = deal(many, 2);  // 40 blocks >= 8 per thread: contiguous
  ASSERT_FALSE(runs[0].empty());
  EXPECT_EQ(runs[0].front(), 0u);
  EXPECT_EQ(runs[1].front(), runs[0].back() + 1);
}


// The invariant check of the force blocks' deal (core/state.hpp; run on every deal in the checking build): the
// deal of a real list on 1 to 3 threads passes; a block dealt twice, to no thread, out of order or one that does
// not exist stops the program naming the broken invariant.
TEST(ThreadBlocksDeathTest, TheDealCheckCatchesBrokenPartitions) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  Scene s = scene();
  evaluate_forces(s.model, s.loading.friction, s.state);
  const PairList unbuilt;  // blocks dealt by their particles: three force blocks and a partial fourth
  const std::size_t n = 3 * kForceBlock + 17;
  for (int threads : {1, 2, 3}) {
    std::vector<std::vector<std::size_t>> dealt(threads);
#pragma omp parallel num_threads(threads)
    if (omp_get_num_threads() == threads) dealt[omp_get_thread_num()] = thread_force_blocks(unbuilt, n);
    check_force_block_partition(dealt, n);  // passes
  }
  check_force_block_partition({thread_force_blocks(s.state.pairs, s.state.particles.size())}, s.state.particles.size());
  EXPECT_DEATH(check_force_block_partition({{0, 1}, {1, 2, 3}}, n), "exactly one thread");
  EXPECT_DEATH(check_force_block_partition({{0, 1}, {3}}, n), "exactly one thread");
  EXPECT_DEATH(check_force_block_partition({{1, 0}, {2, 3}}, n), "ascend");
  EXPECT_DEATH(check_force_block_partition({{0, 1}, {2, 3, 4}}, n), "a dealt force block exists");
}

}  // namespace
}  // namespace celldem
