// The main of every test executable: tests run on one thread unless they ask for more themselves (the
// determinism tests do), so that the suite stays fast when ctest runs tests side by side.
#include <gtest/gtest.h>
#include <omp.h>

#include "core/sanitizers.hpp"

#ifdef CELLDEM_SANITIZED
// LeakSanitizer's suppressions, read when it starts: clang's OpenMP runtime (libomp) leaves its thread pool's
// descriptors allocated at exit, a leak of the runtime and not of ours (GCC's libgomp frees them).
extern "C" const char* __lsan_default_suppressions() { return "leak:libomp.so\n"; }
#endif

int main(int argc, char** argv) {
  omp_set_num_threads(1);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
