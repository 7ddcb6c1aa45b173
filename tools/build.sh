#!/usr/bin/env bash
# Configures and builds celldem (Release) into build/ (or $CELLDEM_BUILD_DIR): everything, or only the
# targets named in $CELLDEM_TARGETS (e.g. CELLDEM_TARGETS=celldem: the binary without the test suite).
set -euo pipefail
cd "$(dirname "$0")/.."
build_dir="${CELLDEM_BUILD_DIR:-build}"
# Ninja where it is installed (tools/install-deps.sh installs it): it compiles a layer's files while the layer
# below is still compiling, which make does not. A build folder keeps the generator it was configured with.
generator=()
if [[ ! -f "$build_dir/CMakeCache.txt" ]] && command -v ninja >/dev/null; then generator=(-G Ninja); fi
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
targets=()
for t in ${CELLDEM_TARGETS:-}; do targets+=(--target "$t"); done
cmake --build "$build_dir" -j "$(nproc)" "${targets[@]}"
