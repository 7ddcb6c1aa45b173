#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, with AddressSanitizer and UndefinedBehaviorSanitizer) and runs each
# for a bounded time. Usage: tools/fuzz.sh [SECONDS_PER_TARGET=60]. Exits non-zero if a target crashes.
# Seeds: the decks in inputs/ and a state file made by the build's celldem (if present).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
out=build-fuzz
mkdir -p "$out"
# -fopenmp: the neighbour search the state reader rebuilds with runs in OpenMP (clang's libomp, libomp-dev).
flags=(-std=c++20 -O1 -g -fopenmp -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined
       -I solver -I /usr/include/eigen3)
# The deck reader resolves --tolerance with the time-to-answer rules, which CMake compiles in from their JSON
# (solver/CMakeLists.txt); the same substitution here.
python3 - <<'PY'
template = open("solver/io/time_to_answer_rules.cpp.in").read()
rules = open("solver/io/time_to_answer_rules.json").read()
text = template.replace("@CELLDEM_TIME_TO_ANSWER_RULES@", rules)
path = "build-fuzz/time_to_answer_rules.cpp"
try:
    unchanged = open(path).read() == text
except OSError:
    unchanged = False
if not unchanged:
    open(path, "w").write(text)
PY
common=(solver/io/deck_reader.cpp solver/io/deck_prescan.cpp solver/io/tolerance.cpp "$out/time_to_answer_rules.cpp"
        solver/core/plan.cpp solver/io/files.cpp solver/io/state_file.cpp solver/neighbor/neighbor_list.cpp
        solver/core/state.cpp solver/core/grading.cpp)
# Each source compiles to its own object, all of them side by side (one clang per core), then both targets link.
stale=0
for target in deck state; do
  if [[ ! -x "$out/fuzz_$target" || -n "$(find solver tests/fuzz -newer "$out/fuzz_$target" -name '*.[ch]pp' | head -1)" ]]; then
    stale=1
  fi
done
if [[ $stale == 1 ]]; then
  mkdir -p "$out/obj"
  printf '%s\n' tests/fuzz/fuzz_deck.cpp tests/fuzz/fuzz_state.cpp "${common[@]}" |
    xargs -P "$(nproc)" -I{} sh -c 'clang++ "$@" -c "$0" -o "'"$out"'/obj/$(basename "$0" .cpp).o"' {} \
      "${flags[@]/-fsanitize=fuzzer,/-fsanitize=fuzzer-no-link,}"
  objects=()
  for source in "${common[@]}"; do objects+=("$out/obj/$(basename "$source" .cpp).o"); done
  for target in deck state; do
    clang++ "${flags[@]}" "$out/obj/fuzz_$target.o" "${objects[@]}" -o "$out/fuzz_$target"
  done
fi
mkdir -p "$out/corpus_deck" "$out/corpus_state"
cp inputs/*.json "$out/corpus_deck/" 2>/dev/null || true
if [[ -x build/celldem && ! -f "$out/corpus_state/seed.state" ]]; then
  # A tiny prepared sample makes a realistic seed for the state reader.
  cat > "$out/seed.json" <<'JSON'
{"format":1,"sample":{"count":20,"diameters":{"list":[0.003,0.004]},"density":2650,"seed":3,"grid_spacing":0.0045},
 "contact":{"kn":1e6,"kt":1e6},"damping":{"translational":0.05,"rotational":0.05},"time_step":1e-6,
 "prepare":{"target_pressure":1e5,"equilibrium":{"min_steps":10,"max_steps":3000,"unbalanced_force_ratio":1,"pressure_tolerance":1,"stress_tolerance":1,"check_interval":10}}}
JSON
  ./build/celldem run "$out/seed.json" --out "$out/seed-run" --force --quiet && cp "$out/seed-run/prepared.state" "$out/corpus_state/seed.state"
fi
# Both targets at once, one per core, each on one OpenMP thread (the state reader's neighbour search runs in
# OpenMP: two teams of nproc threads on nproc cores would slow both); each one's log is read after both ended.
targets=(deck state)
pids=()
trap 'kill "${pids[@]}" 2>/dev/null || true' EXIT
for target in "${targets[@]}"; do
  echo "fuzzing the $target reader for ${seconds}s"
  OMP_NUM_THREADS=1 OMP_WAIT_POLICY=PASSIVE ASAN_OPTIONS=detect_leaks=0 "$out/fuzz_$target" \
    -max_total_time="$seconds" -max_len=65536 -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
    "$out/corpus_$target" 2> "$out/fuzz_$target.log" &
  pids+=($!)
done
status=0
for k in "${!targets[@]}"; do
  target=${targets[$k]}
  if ! wait "${pids[$k]}"; then
    echo "fuzz_$target found a failure:"; tail -40 "$out/fuzz_$target.log"; status=1
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$out/fuzz_$target.log" | sed "s/^/  $target: /" || true
done
exit $status
