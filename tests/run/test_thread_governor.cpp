// The thread governor (solver/run/thread_governor.hpp): its trial schedule, and that it says when the thread
// count changes (the step loop then regroups). (That results do not depend on the count it picks is tested
// by the runner's one-and-two-thread byte comparisons, which run through its trials.)
#include <gtest/gtest.h>

#include "run/thread_governor.hpp"

namespace celldem {
namespace {

TEST(ThreadGovernor, TrialsOnScheduleAndSaysWhenTheCountChanges) {
  ThreadGovernor g(2, /*period=*/50, /*window=*/5);
  for (int k = 0; k < 10; ++k) EXPECT_FALSE(g.step_done());  // the first trial starts after 2 windows, on 2
  EXPECT_EQ(g.trials(), 0);
  EXPECT_EQ(g.current(), 2);                                  // timing the full count first
  for (int k = 0; k < 4; ++k) EXPECT_FALSE(g.step_done());
  EXPECT_TRUE(g.step_done());                                 // then one thread: the caller must regroup
  EXPECT_EQ(g.current(), 1);
  for (int k = 0; k < 4; ++k) EXPECT_FALSE(g.step_done());
  const bool changed = g.step_done();                         // the trial ends on the faster count
  EXPECT_EQ(g.trials(), 1);
  EXPECT_TRUE(g.current() == 1 || g.current() == 2);
  EXPECT_EQ(changed, g.current() == 2);
  for (int k = 0; k < 60; ++k) g.step_done();                 // a period, then the next trial
  EXPECT_EQ(g.trials(), 2);
  ThreadGovernor one(1, 10, 2);
  for (int k = 0; k < 100; ++k) EXPECT_FALSE(one.step_done());
  EXPECT_EQ(one.trials(), 0);
  EXPECT_EQ(one.current(), 1);
}

}  // namespace
}  // namespace celldem
