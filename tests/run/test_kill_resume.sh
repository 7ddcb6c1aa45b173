#!/usr/bin/env bash
# Kills runs at random moments (SIGKILL, and SIGINT once) and resumes them until they finish; every
# finished series.csv and state file must be byte-identical to those of an uninterrupted run.
# Usage: test_kill_resume.sh CELLDEM [KILLS=6]
set -uo pipefail
celldem="$1"
kills="${2:-6}"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# 150 spheres, prepared and tested twice (TTC, PSC), checkpoints every 700 steps.
cp "$(dirname "$0")/small_run.json" "$work/deck.json"
fail() { echo "FAIL: $*"; exit 1; }

start=$(date +%s.%N)
"$celldem" run "$work/deck.json" --out "$work/ref" --quiet --threads 1 || fail "reference run"
ref_seconds=$(echo "$(date +%s.%N) - $start" | bc)
echo "uninterrupted run: ${ref_seconds}s"

# A batch job's log (stdout to a file) holds every line written before a SIGKILL: stdout is line-buffered
# when it is not a terminal. Longer tests, so that the run is still going when its first test starts.
sed 's/"strain":0.006/"strain":0.03/g' "$work/deck.json" > "$work/long.json"
"$celldem" run "$work/long.json" --out "$work/logged" --threads 1 > "$work/stdout.log" 2>/dev/null &
pid=$!
for ((k = 0; k < 300; ++k)); do grep -q "ttc: starting" "$work/stdout.log" 2>/dev/null && break; sleep 0.1; done
kill -0 $pid 2>/dev/null || fail "stdout reached its log only when the run ended (buffered), or the run failed"
kill -KILL $pid; wait $pid 2>/dev/null
grep -q "prepare: done" "$work/stdout.log" || fail "the log of a killed run lacks the line of its finished preparation"

# Random kill points spread over the run's duration (portable seed: the test is reproducible in spirit,
# not in timing, which is the point).
RANDOM=$$
"$celldem" run "$work/deck.json" --out "$work/cut" --quiet --threads 2 &
pid=$!
interrupted=0
for ((k = 0; k < kills; ++k)); do
  # $((RANDOM % 1000)) in the shell: bc's % at scale=3 is always 0, which put every kill at 0.05 s.
  delay=$(echo "scale=3; $ref_seconds * $((RANDOM % 1000)) / 1000 / $kills + 0.05" | bc)
  sleep "$delay"
  if ! kill -0 $pid 2>/dev/null; then break; fi
  if ((k == 1)); then
    kill -INT $pid; wait $pid; rc=$?
    [[ $rc -eq 130 || $rc -eq 0 ]] || fail "SIGINT: exit code $rc, expected 130"
  else
    kill -KILL $pid; wait $pid 2>/dev/null
  fi
  interrupted=$((interrupted + 1))
  if [[ -f "$work/cut/progress.json" ]]; then
    "$celldem" run "$work/deck.json" --out "$work/cut" --resume --quiet --threads 2 &
  else  # killed before anything was written: start again
    "$celldem" run "$work/deck.json" --out "$work/cut" --force --quiet --threads 2 &
  fi
  pid=$!
done
wait $pid || fail "the last resumed run failed"
echo "interrupted $interrupted times"

for f in prepare/series.csv ttc/series.csv psc/series.csv prepared.state ttc/final.state psc/final.state; do
  cmp -s "$work/ref/$f" "$work/cut/$f" || fail "$f differs from the uninterrupted run"
done
for stage in prepare ttc psc; do
  [[ ! -f "$work/cut/$stage/checkpoint.state" ]] || fail "a finished run left the checkpoint of $stage behind"
done
echo "byte-identical after $interrupted interruptions"

# The figure and report tools on this real (small) run.
root="$(cd "$(dirname "$0")/../.." && pwd)"
/usr/bin/python3 "$root/tools/report.py" "$work/ref" > "$work/report.log" 2>&1 || { cat "$work/report.log"; fail "report.py"; }
for f in report.md figures/fig02_stress_ratio.png figures/fig12_macro_micro.png; do
  [[ -s "$work/ref/$f" ]] || fail "report.py did not write $f"
done
grep -q "ttc" "$work/ref/report.md" || fail "report.md does not mention the ttc test"
echo "PASS"
