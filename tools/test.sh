#!/usr/bin/env bash
# The test suite: install what is missing (LAMMPS and LIGGGHTS included, for the cross-checks), build, run
# every test with ctest; then the unit tests again under AddressSanitizer + UndefinedBehaviorSanitizer with the
# invariant checks compiled in (CELLDEM_CHECKS, core/check.hpp), and
# the deck and state-file fuzzers side by side for a bounded time (CELLDEM_FUZZ_SECONDS per target, default 20:
# about 100,000 decks and 700,000 state files; the suite stays inside its CI budget of 20 minutes).
# CELLDEM_QUICK=1 skips the sanitizer build and the fuzzers.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh --with-crosscheck
bash tools/build.sh -DCELLDEM_WERROR=ON
(cd "${CELLDEM_BUILD_DIR:-build}" && ctest --output-on-failure -j 2 "$@")
if [[ "${CELLDEM_QUICK:-0}" != 1 ]]; then
  echo "== unit tests under AddressSanitizer + UndefinedBehaviorSanitizer, invariants checked (CELLDEM_CHECKS) =="
  # Only the unit tests' executables (the binary and the whole-run tests are not run here). The physics layer
  # and the neighbour test at -O1 or more (at -O0 the packing tests and the brute-force neighbour check run 10 to
  # 100 times longer; solver/CMakeLists.txt gives clang -O2), the rest at -O0 (CMakeLists.txt's
  # CELLDEM_COLD_OPTIMIZATION), with line tables only (-g1: the reports' stack traces keep file and line; full
  # debug information doubles the build). clang where it is installed (tools/install-deps.sh --with-crosscheck):
  # from a clean clone it built this in 2.5 minutes where GCC took 7.8 (docs/performance.md, "The test suite's
  # time"); a folder keeps the compiler it was configured with.
  # Its warnings are errors under clang (GCC's sanitizer builds warn falsely, so not there).
  compiler=()
  if [[ ! -f build-asan/CMakeCache.txt ]] && command -v clang++ >/dev/null; then
    compiler=(-DCMAKE_CXX_COMPILER=clang++ -DCELLDEM_WERROR=ON)
  fi
  CELLDEM_BUILD_DIR=build-asan \
    CELLDEM_TARGETS="test_core test_cell test_neighbor test_contact test_integrate test_measure test_io test_step test_run_rules" \
    bash tools/build.sh "${compiler[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
      -DCELLDEM_SANITIZE=ON -DCELLDEM_CHECKS=ON
  (cd build-asan && ASAN_OPTIONS=detect_leaks=1 ctest --output-on-failure -j 2 -L unit)
  echo "== fuzzing =="
  bash tools/fuzz.sh "${CELLDEM_FUZZ_SECONDS:-20}"
fi
