#!/usr/bin/env bash
# Kills drawn over a run's file events, not over time: every window between two writes is reachable. A small run
# with probes, snapshots by e1 and a rate check is made once with every file event logged (tests/support/kill_at.c,
# LD_PRELOAD); each trial draws an event and a moment (before it, after it, or a write torn in half), kills the run
# there with SIGKILL, then resumes it (the first resume itself killed at a drawn event half of the time) until it
# ends. Every finished file must be the uninterrupted run's bytes, and summary.json its values (control errors and
# verdicts included; only times and speeds differ). A trial whose kill did not land (the run ended first), or landed
# at another operation or file than the reference run's event of that number, is counted as skipped, never as passed.
# Usage: test_file_events.sh CELLDEM KILL_AT_LIBRARY [SEED=1] [SECONDS=120] [MIN_TRIALS=20] [PATTERN]
# PATTERN (grep -E over the event log's "N op path" lines) draws only among matching events, e.g.
# 'rename .*checkpoint' for the windows after each checkpoint's commit. ENERGY_BUDGET=1 in the environment runs the
# deck with "energy_budget": true (its totals then travel in each checkpoint's record). FILE_EVENT_CLASSES=1 draws
# nothing: it visits every class of event (its op and its path with the numbers in it made N: one series row, one
# stage's checkpoint commit, one rung's summary ...) at its first and its last event, killed before and after it
# and, a write, torn (SECONDS and MIN_TRIALS are then ignored).
set -uo pipefail
celldem="$1"
interposer="$2"
seed="${3:-1}"
budget="${4:-120}"
min_trials="${5:-20}"
pattern="${6:-.}"
RANDOM=$seed
work=$(mktemp -d)
trap 'jobs -p | xargs -r kill -9 2>/dev/null; rm -rf "$work"' EXIT
here="$(dirname "$0")"
fail() { echo "FAIL: $*"; exit 1; }
grep -q '"output_interval":250}' "$here/small_run.json" || fail "small_run.json changed: adapt this test"
# small_run.json's TTC and PSC, shorter, each with probes at e1 = 0.002 and at the peak and snapshots by e1.
sed -e 's/"strain":0.006/"strain":0.004/g' \
    -e 's/"output_interval":250}/"output_interval":250,"snapshots":{"e1":[0.001,0.003]},"probes":{"at_e1":[0.002],"at":["peak"],"kind":"stress","plane":"rendulic","directions":2,"magnitudes":[2000],"steps":200,"hold_steps":50}}/g' \
    "$here/small_run.json" > "$work/deck.json"
if [[ "${ENERGY_BUDGET:-0}" == 1 ]]; then sed -i 's/^{"format":1,/{"format":1,"energy_budget":true,/' "$work/deck.json"; fi
args=(--verify-rate --quiet --threads 1)

# The files a finished run leaves, compared byte for byte (summary.json: by value, without times and speeds).
finished_files() {
  (cd "$1" && find . -type f ! -name summary.json ! -name progress.json ! -name run.lock ! -name '*.log' \
     ! -name celldem.log | sort)
}
same_as_reference() {
  local d="$1" f
  [[ "$(finished_files "$work/ref")" == "$(finished_files "$d")" ]] ||
    { why="other files: $(diff <(finished_files "$work/ref") <(finished_files "$d") | grep '^[<>]' | head -3 | tr '\n' ' ')"; return 1; }
  while read -r f; do
    cmp -s "$work/ref/$f" "$d/$f" || { why="$f differs from the uninterrupted run's"; return 1; }
  done < <(finished_files "$d")
  /usr/bin/python3 - "$work/ref/summary.json" "$d/summary.json" > "$work/why" 2>&1 <<'EOF' || { why="summary.json: $(head -c 400 "$work/why")"; return 1; }
import json, re, sys
timing = re.compile(r"wall|per_s|elapsed|seconds|_s$|threads|speed")
def strip(v, path=""):
    if isinstance(v, dict):
        return {k: strip(x, f"{path}/{k}") for k, x in v.items() if not timing.search(k)}
    if isinstance(v, list):
        return [strip(x, path) for x in v]
    return v
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
def diff(x, y, path=""):
    if type(x) != type(y):
        return f"{path}: {x!r} != {y!r}"
    if isinstance(x, dict):
        for k in sorted(set(x) | set(y)):
            if k not in x or k not in y:
                return f"{path}/{k}: only in {'the reference' if k in x else 'the resumed run'}"
            d = diff(x[k], y[k], f"{path}/{k}")
            if d: return d
        return ""
    if isinstance(x, list):
        if len(x) != len(y): return f"{path}: {len(x)} != {len(y)} items"
        for i, (p, q) in enumerate(zip(x, y)):
            d = diff(p, q, f"{path}[{i}]")
            if d: return d
        return ""
    return "" if x == y or (x != x and y != y) else f"{path}: {x!r} != {y!r}"
d = diff(a, b)
if d:
    print(d)
    sys.exit(1)
EOF
}

# The reference, with every file event of the run listed.
start=$(date +%s.%N)
CELLDEM_KILL_LOG="$work/events.log" LD_PRELOAD="$interposer" "$celldem" run "$work/deck.json" --out "$work/ref" "${args[@]}" \
  2>"$work/err" || { cat "$work/err"; fail "reference run"; }
events=$(wc -l < "$work/events.log")
((events > 50)) || fail "the interposer saw only $events file events: is $interposer preloaded?"
mapfile -t drawn < <(grep -E -- "$pattern" "$work/events.log" | cut -d' ' -f1)
((${#drawn[@]} > 0)) || fail "no file event matches '$pattern'"
echo "reference: $(echo "$(date +%s.%N) - $start" | bc) s, $events file events ($(cut -d' ' -f2 "$work/events.log" | sort | uniq -c | tr '\n' ' ' | tr -s ' '))"

# The class visit: "N when" per trial, each class's first and last event (one event: once) at each moment; its
# last line is the count of classes.
visits=()
if [[ "${FILE_EVENT_CLASSES:-0}" == 1 ]]; then
  mapfile -t visits < <(grep -E -- "$pattern" "$work/events.log" | sed "s|$work/ref/||" | awk '
    { cls = $2 " " $3; gsub(/[0-9]+/, "N", cls)
      if (!(cls in first)) { first[cls] = $1; order[++n] = cls; op[cls] = $2 }
      last[cls] = $1 }
    END { for (i = 1; i <= n; ++i) { c = order[i]
            split(first[c] (last[c] != first[c] ? " " last[c] : ""), at, " ")
            for (k in at) { print at[k], "after"; print at[k], "before"; if (op[c] == "write") print at[k], "torn" } }
          print n }')
  classes=${visits[-1]}
  unset 'visits[-1]'
  echo "class visit: $classes classes of event, ${#visits[@]} trials"
fi

passed=0 failed=0 skipped=0 trials=0
declare -A failed_at
t0=$SECONDS
while if ((${#visits[@]})); then ((trials < ${#visits[@]})); else ((trials < min_trials || SECONDS - t0 < budget)); fi; do
  trials=$((trials + 1))
  d="$work/t"
  rm -rf "$d"
  if ((${#visits[@]})); then
    read -r n when <<< "${visits[trials - 1]}"
  else
    n=${drawn[(RANDOM * 32768 + RANDOM) % ${#drawn[@]}]}
    when=(after before torn)
    when=${when[RANDOM % 3]}
  fi
  what="event $n ($when): $(sed -n "${n}p" "$work/events.log" | cut -d' ' -f2- | sed "s|$work/ref/||")"
  rm -f "$work/kill.log"
  { CELLDEM_KILL_AT=$n CELLDEM_KILL_WHEN=$when CELLDEM_KILL_LOG="$work/kill.log" LD_PRELOAD="$interposer" \
      "$celldem" run "$work/deck.json" --out "$d" "${args[@]}"; } 2>/dev/null  # (and the shell's "Killed")
  rc=$?
  # The kill landed, and at the reference run's event n (the same operation on the same file): else nothing that
  # was meant was tested.
  if ((rc != 137)) || [[ "$(tail -1 "$work/kill.log")" != "$(sed -n "${n}p" "$work/events.log" | sed "s|$work/ref|$d|") KILL" ]]; then
    skipped=$((skipped + 1))
    continue
  fi
  why=""
  second=""
  ((RANDOM % 2)) && second=$((1 + (RANDOM * 32768 + RANDOM) % events))
  for ((k = 0; k < 6; ++k)); do
    mode=--resume
    [[ -f $d/progress.json ]] || mode=--force  # killed before the run wrote anything to resume: start it again
    if [[ -n $second ]]; then
      { CELLDEM_KILL_AT=$second LD_PRELOAD="$interposer" "$celldem" run "$work/deck.json" --out "$d" "${args[@]}" $mode \
          2>"$work/err"; } 2>/dev/null
      rc=$?
      second=""
      ((rc == 137)) && { what="$what, then resume killed"; continue; }
    else
      "$celldem" run "$work/deck.json" --out "$d" "${args[@]}" $mode 2>"$work/err"
      rc=$?
    fi
    break
  done
  if ((rc != 0)); then
    why="resume exited $rc: $(tail -1 "$work/err")"
  else
    same_as_reference "$d"
  fi
  if [[ -z $why ]]; then
    passed=$((passed + 1))
  else
    failed=$((failed + 1))
    echo "failed: $what: $why"
  fi
done
echo "file-event trials: $trials drawn, $passed passed, $failed failed, $skipped skipped (the kill did not land at its event)"
((failed == 0)) || fail "$failed trials failed"
((passed > 0)) || fail "no trial set up what it meant to test"
echo "PASS"
