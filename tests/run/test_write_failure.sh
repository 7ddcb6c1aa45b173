#!/usr/bin/env bash
# Writes that fail part-way (the file-size limit of the process, RLIMIT_FSIZE, makes write() fail with
# EFBIG exactly as a full disk fails with ENOSPC): the run must stop with exit code 1 and a message naming
# the file and the system's reason, leave no partial row and no temporary file, and, once writes succeed
# again, `--resume` must finish with results byte-identical to an undisturbed run.
# Usage: test_write_failure.sh CELLDEM
set -uo pipefail
celldem="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
# The kill-and-resume deck (150 spheres, TTC and PSC) with a row every other step in the tests, so that a
# series outgrows the state files.
sed 's/"output_interval":250/"output_interval":2/g' "$(dirname "$0")/small_run.json" > "$work/deck.json"
grep -q '"output_interval":2}' "$work/deck.json" || fail "small_run.json changed: adapt this test"
"$celldem" run "$work/deck.json" --out "$work/ref" --quiet --threads 1 || fail "reference run"
series_kb=$(( $(stat -c %s "$work/ref/ttc/series.csv") / 1024 ))
state_kb=$(( $(stat -c %s "$work/ref/prepared.state") / 1024 ))
echo "reference: ttc/series.csv ${series_kb} KiB, prepared.state ${state_kb} KiB"

# Runs the deck with every file limited to $1 KiB; prints the exit code, keeps stderr in $work/err.
limited_run() {
  (ulimit -f "$1"; trap '' XFSZ; exec "$celldem" run "$work/deck.json" --out "$work/cut" "${@:2}" --quiet --threads 1) \
    2> "$work/err"
  echo $?
}
check_failure() {  # $1: what was expected to fail
  [[ $rc -eq 1 ]] || { cat "$work/err"; fail "$1: exit code $rc, expected 1"; }
  grep -q "File too large" "$work/err" || { cat "$work/err"; fail "$1: the message does not give the system's reason"; }
  grep -q "$2" "$work/err" || { cat "$work/err"; fail "$1: the message does not name $2"; }
  [[ -z $(find "$work/cut" -name '*.tmp') ]] || fail "$1: a temporary file was left behind"
  for f in $(find "$work/cut" -name series.csv); do
    [[ -z $(tail -c 1 "$f") ]] || fail "$1: $f ends in a partial row"
    fields=$(head -1 "$f" | tr ',' '\n' | wc -l)
    awk -F, -v n="$fields" 'NF != n { exit 1 }' "$f" || fail "$1: $f holds a row with a wrong field count"
  done
  echo "ok: $1 -> $(grep -m1 'error' "$work/err")"
}

# 1. The series outgrows the limit during the test (the state files are smaller than the limit).
limit=$(( (state_kb + series_kb) / 2 + 2 ))
((limit > state_kb + 1 && limit < series_kb)) || fail "cannot choose a limit between the state and the series sizes"
rc=$(limited_run "$limit")
check_failure "series row write" "ttc/series.csv"
# 2. Space "comes back": the resumed run ends byte-identical to the reference.
"$celldem" run "$work/deck.json" --out "$work/cut" --resume --quiet --threads 1 || fail "resume after the failed row"
for f in prepare/series.csv ttc/series.csv prepared.state ttc/final.state; do
  cmp -s "$work/ref/$f" "$work/cut/$f" || fail "$f differs from the undisturbed run after resuming"
done
echo "ok: resumed after the failed row, results byte-identical"

# 3. A state file that cannot be written (the limit below the size of a checkpoint): exit 1, not "invalid".
rm -rf "$work/cut"
rc=$(limited_run $((state_kb / 2)))
check_failure "state file write" "checkpoint.state"
grep -q "invalid" "$work/err" && fail "a failed write is reported as invalid input"
"$celldem" run "$work/deck.json" --out "$work/cut" --resume --quiet --threads 1 || fail "resume after the failed checkpoint"
cmp -s "$work/ref/ttc/series.csv" "$work/cut/ttc/series.csv" || fail "series differs after resuming a failed checkpoint"
echo "ok: resumed after the failed checkpoint, results byte-identical"
echo "PASS"
