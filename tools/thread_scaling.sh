#!/usr/bin/env bash
# Thread scaling of one run on a many-core machine, and what the machine itself allows:
#   bash tools/thread_scaling.sh OUT STATE [DECK]
# 1. `celldem bench --scaling`: the paper's TTC on STATE (8000 spheres), 16 copies (128,000) and 125 copies
#    (1,000,000), on 1, 2, 4, 8, ... threads and the number of CPUs this process may use: OUT/bench/bench.json and
#    OUT/bench/scaling.md (with the speed-up and parallel efficiency of each row).
# 2. The machine's own scaling for this kernel: N independent one-thread benches at once, each pinned to a CPU of
#    its own (N = a quarter, half and all of the CPUs; one alone is the solo bench), and the first CPU beside each
#    other one (a pair that slows both shares a physical core): OUT/probe.log. A run's threads meet every step, so
#    the slowest of N copies bounds what N threads of one run can reach.
# 3. With DECK (a deck that starts from a prepared state): whole `celldem run` processes on 1 and 2 threads,
#    alternated, 3 rounds: OUT/whole.log. A deck's tests run side by side when threads are spare, so a deck of
#    one test times one run on 2 threads, and a deck of two times two runs on one thread each.
# Env: CELLDEM (default build/celldem), STEPS (10000), REPEATS (3), PROBE_STEPS (3000).
set -euo pipefail
if [[ $# -lt 2 ]]; then
  echo "usage: bash tools/thread_scaling.sh OUT STATE [DECK]" >&2
  exit 2
fi
# Paths as given, from where the script was called; then the repository root (inputs/paper.json, tools/).
out=$(realpath -m "$1") state=$(realpath -m "$2") deck=${3:+$(realpath -m "$3")}
bin=$(realpath -m "${CELLDEM:-$(dirname "$0")/../build/celldem}")
cd "$(dirname "$0")/.."
[[ -x $bin ]] || { echo "thread_scaling: no celldem binary at $bin (build it: bash tools/build.sh)" >&2; exit 2; }
[[ -f $state ]] || { echo "thread_scaling: no state file $state" >&2; exit 2; }
[[ -z $deck || -f $deck ]] || { echo "thread_scaling: no deck $deck" >&2; exit 2; }
if [[ -e $out/bench/bench.json || -e $out/probe.log || -e $out/whole.log ]]; then
  echo "thread_scaling: $out already holds results; remove it first" >&2
  exit 2
fi
command -v taskset >/dev/null || { echo "thread_scaling: taskset (util-linux) is needed to pin the probes" >&2; exit 2; }

# The CPUs this process may use, by number (a container's or cpuset's need not be 0 .. n-1).
cpus=()
IFS=, read -ra ranges <<<"$(taskset -pc $$ | sed 's/.*: *//')"
for r in "${ranges[@]}"; do
  if [[ $r == *-* ]]; then for ((c = ${r%-*}; c <= ${r#*-}; ++c)); do cpus+=("$c"); done; else cpus+=("$r"); fi
done
cores=${#cpus[@]}
threads=1
for ((t = 2; t < cores; t *= 2)); do threads+=",$t"; done
((cores > 1)) && threads+=",$cores"
mkdir -p "$out/probe-runs"
{ echo "CPUs ${cpus[*]}"; lscpu 2>/dev/null || true; uptime; } >"$out/host.txt"

"$bin" bench --deck inputs/paper.json --state "$state" --scaling --copies 1,16,125 --threads "$threads" \
  --steps "${STEPS:-10000}" --warmup 1000 --repeats "${REPEATS:-3}" --out "$out/bench" 2>&1 | tee "$out/bench.log"
/usr/bin/python3 tools/plot_bench.py "$out/bench" || python3 tools/plot_bench.py "$out/bench" ||
  echo "thread_scaling: no scaling.md (plot_bench.py needs Python with matplotlib); bench.json has the rates" >&2

one() {  # one CPU TAG: a one-thread bench pinned to CPU, its particle-steps/s into probe-runs/TAG.rate
  taskset -c "$1" "$bin" bench --deck inputs/paper.json --state "$state" --threads 1 --steps "${PROBE_STEPS:-3000}" \
    --warmup 200 --repeats 1 --out "$out/probe-runs/$2" --force 2>&1 | awk '/celldem-t1 /{print $2}' >"$out/probe-runs/$2.rate"
  [[ -s $out/probe-runs/$2.rate ]] || { echo "thread_scaling: the bench on CPU $1 gave no rate" >&2; return 1; }
}
together() {  # together CPU...: one() on each at once; their rates, in order, on one line
  local pids=() c
  for c in "$@"; do one "$c" "cpu$c" & pids+=($!); done
  for c in "${pids[@]}"; do wait "$c" || return 1; done
  for c in "$@"; do cat "$out/probe-runs/cpu$c.rate"; done | tr '\n' ' '
}
probe=$out/probe.log
echo "one-thread benches pinned to CPUs, particle-steps/s" >"$probe"
solo=$(together "${cpus[0]}")
echo "solo cpu${cpus[0]} $solo" | tee -a "$probe"
for c in "${cpus[@]:1}"; do
  rates=$(together "${cpus[0]}" "$c")
  echo "pair cpu${cpus[0]}+cpu$c $rates" | tee -a "$probe"
done
last=1  # (one at once is the solo bench above)
for n in $((cores / 4)) $((cores / 2)) "$cores"; do
  ((n > last)) || continue
  last=$n
  rates=$(together "${cpus[@]:0:n}")
  echo "$rates" | awk -v n="$n" -v solo="$solo" '{s = 0; m = $1; for (i = 1; i <= NF; ++i) {s += $i; if ($i < m) m = $i}
    printf "concurrent %d: mean %.3g (%.2f of solo), slowest %.3g (%.2f of solo): %s\n", n, s / NF, s / NF / solo, m, m / solo, $0}' \
    | tee -a "$probe"
done

if [[ -n $deck ]]; then
  for r in 1 2 3; do
    for t in 1 2; do
      rm -rf "$out/whole-run"
      start=$(date +%s%N)
      "$bin" run "$deck" --out "$out/whole-run" --quiet --threads "$t" --fixed-threads >/dev/null
      ms=$((($(date +%s%N) - start) / 1000000))
      printf 'round %d threads %d seconds %d.%03d\n' "$r" "$t" $((ms / 1000)) $((ms % 1000)) | tee -a "$out/whole.log"
    done
  done
  rm -rf "$out/whole-run"
fi
rm -rf "$out/probe-runs"
uptime >>"$out/host.txt"
