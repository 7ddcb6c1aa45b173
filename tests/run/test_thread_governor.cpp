// The thread governor (solver/run/thread_governor.hpp): its trial schedule, and that it leaves OpenMP at the
// stage's thread count. (That results do not depend on the count it picks is tested by the runner's
// one-and-two-thread byte comparisons, which run through its trials.)
#include <gtest/gtest.h>
#include <omp.h>

#include "run/thread_governor.hpp"

namespace celldem {
namespace {

TEST(ThreadGovernor, TrialsOnScheduleAndRestoresTheCount) {
  const int saved = omp_get_max_threads();
  omp_set_num_threads(2);
  {
    ThreadGovernor g(2, /*period=*/50, /*window=*/5);
    for (int k = 0; k < 10; ++k) g.step_done();  // the first trial starts after 2 windows
    EXPECT_EQ(g.trials(), 0);
    EXPECT_EQ(g.current(), 2);                    // timing the full count first
    for (int k = 0; k < 5; ++k) g.step_done();
    EXPECT_EQ(g.current(), 1);                    // then one thread
    EXPECT_EQ(omp_get_max_threads(), 1);
    for (int k = 0; k < 5; ++k) g.step_done();
    EXPECT_EQ(g.trials(), 1);
    EXPECT_TRUE(g.current() == 1 || g.current() == 2);
    EXPECT_EQ(omp_get_max_threads(), g.current());
    for (int k = 0; k < 60; ++k) g.step_done();   // a period, then the next trial
    EXPECT_EQ(g.trials(), 2);
  }
  EXPECT_EQ(omp_get_max_threads(), 2);
  {
    ThreadGovernor one(1, 10, 2);
    for (int k = 0; k < 100; ++k) one.step_done();
    EXPECT_EQ(one.trials(), 0);
    EXPECT_EQ(omp_get_max_threads(), 2);  // never touched
  }
  EXPECT_EQ(omp_get_max_threads(), 2);
  omp_set_num_threads(saved);
}

}  // namespace
}  // namespace celldem
