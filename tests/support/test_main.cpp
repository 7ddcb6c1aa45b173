// The main of every test executable: tests run on one thread unless they ask for more themselves (the
// determinism tests do), so that the suite stays fast when ctest runs tests side by side.
#include <gtest/gtest.h>
#include <omp.h>

int main(int argc, char** argv) {
  omp_set_num_threads(1);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
