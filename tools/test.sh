#!/usr/bin/env bash
# The test suite: install what is missing (LAMMPS and LIGGGHTS included, for the cross-checks), build, and
# run every test with ctest.
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh --with-crosscheck
bash tools/build.sh -DCELLDEM_WERROR=ON
cd "${CELLDEM_BUILD_DIR:-build}"
ctest --output-on-failure -j 2 "$@"
