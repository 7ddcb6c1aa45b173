#!/usr/bin/env bash
# Resumes after a kill between a test's last checkpoint and the outputs of a leg's end, where a checkpoint is due at
# that leg's last step (checkpoint_interval divides it): the files and summary must be an uninterrupted run's.
#   stage_end  small_run.json's ttc alone, 6000 steps, a checkpoint every 2000: killed before its end snapshot
#              (forces, particle stresses, contact forces)
#   leg_end    the same in two legs (x1 to 0.003, then 0.006), a checkpoint every 1000 and a row every 700: killed
#              before the row of leg 0's end (step 3000, not a row step: written once the leg has ended)
# A state file keeps no per-pair forces: a checkpoint written at a leg's last step resumed with no step left in the
# leg, and wrote those outputs from zero forces (every force of the end snapshot, the stresses of the leg's end row).
# So none is written there; the killed run's last checkpoint is an earlier step. The kill is SIGKILL just after the
# rename of ttc's last checkpoint before those outputs (tests/support/kill_at.c, LD_PRELOAD). A case whose kill did
# not land there is skipped (then exit 77: ctest reports the test skipped), never passed.
# Usage: test_resume_at_end.sh CELLDEM LIBKILL_AT
set -uo pipefail
celldem="$(realpath "$1")"
kill_at="$(realpath "$2")"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
here="$(dirname "$0")"
failed=0 skipped=0 passed=0

# $1: the case; writes $work/$1.json from small_run.json.
make_deck() {
  /usr/bin/python3 - "$here/small_run.json" "$work/$1.json" "$1" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["tests"] = [t for t in d["tests"] if t["name"] == "ttc"]
t = d["tests"][0]
assert t["end"] == {"axis": "x1", "strain": 0.006} and t["axes"]["x1"] == {"strain_increment": 1e-6}
t["snapshots"] = {"e1": [0.002], "format": "ascii"}
if sys.argv[3] == "stage_end":
    d["checkpoint_interval"] = 2000
else:
    d["checkpoint_interval"], t["output_interval"] = 1000, 700
    axes = t.pop("axes")
    t["legs"] = [{"axes": axes, "end": {"axis": "x1", "strain": s}} for s in (0.003, 0.006)]
    del t["end"]
json.dump(d, open(sys.argv[2], "w"))
EOF
}

# The first event of the outputs the kill must come before, from the uninterrupted run's log ($1: the case, $2: the
# run folder); sets $step (the leg's last step) and $event, or $why.
outputs_event() {
  local r="$2" series="$work/ref-$1/ttc/series.csv" line
  if [[ $1 == stage_end ]]; then
    step=$(tail -1 "$series" | cut -d, -f1)
    event=$(grep -m1 " $r/ttc/snapshots/ttc_\(contacts_\)\?$step\." "$work/$1.log" | cut -d' ' -f1)
  else
    step=3000
    # The appends to series.csv, one write each (the header, then each row): the leg-end row's is its line's.
    (($(grep -c "^[0-9]* write $r/ttc/series.csv$" "$work/$1.log") == $(wc -l < "$series"))) ||
      { why="series.csv's appends are not one write a row"; return 1; }
    line=$(cut -d, -f1 "$series" | grep -n -x "$step" | cut -d: -f1)
    [[ -n $line ]] || { why="no row at step $step"; return 1; }
    ((step % 700 != 0)) || { why="step $step is a row step"; return 1; }
    event=$(grep "^[0-9]* write $r/ttc/series.csv$" "$work/$1.log" | sed -n "${line}p" | cut -d' ' -f1)
  fi
  [[ -n $event ]] || { why="no event of the outputs at step $step listed"; return 1; }
}

# $1: the case. 0 passed, 1 failed, 2 skipped; $why says why.
run_case() {
  local c="$1" r="$work/$1" rc n at interval note=""
  make_deck "$c" || { why="small_run.json changed: adapt this test"; return 1; }
  interval=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["checkpoint_interval"])' "$work/$c.json")
  run() { "$celldem" run "$work/$c.json" --out "$r" --quiet --threads 1 "$@"; }
  # The uninterrupted run, its file events listed (at the folder the killed run uses: the same paths).
  CELLDEM_KILL_LOG="$work/$c.log" LD_PRELOAD="$kill_at" run 2>"$work/err" || { why="the uninterrupted run: $(tail -3 "$work/err")"; return 1; }
  mv "$r" "$work/ref-$c"
  outputs_event "$c" "$r" || return 1
  ((step % interval == 0)) || { why="skipped: step $step is not a checkpoint step"; return 2; }
  n=$(awk -v e="$event" -v p="$r/ttc/checkpoint.state" '$1 < e && $2 == "rename" && $3 == p { n = $1 } END { print n }' "$work/$c.log")
  [[ -n $n ]] || { why="skipped: no checkpoint of ttc before event $event"; return 2; }
  { CELLDEM_KILL_AT=$n CELLDEM_KILL_LOG="$work/$c.kill.log" LD_PRELOAD="$kill_at" run 2>/dev/null & wait $!; } 2>/dev/null
  rc=$?
  # Proof the kill landed where asked: SIGKILL at that rename, ttc not finished, the outputs at $step not written.
  ((rc == 137)) && tail -1 "$work/$c.kill.log" | grep -q "^$n rename $r/ttc/checkpoint.state KILL$" ||
    { why="skipped: the kill did not land at event $n (exit $rc: $(tail -1 "$work/$c.kill.log"))"; return 2; }
  # The step of the checkpoint the resume goes on from: its row, or the last before it, is the killed series' last.
  at=$(tail -1 "$r/ttc/series.csv" | cut -d, -f1)
  if [[ ! -f $r/ttc/checkpoint.state || -e $r/ttc/final.state || -e $r/ttc/snapshots/ttc_$step.dump ]] ||
    { [[ $c == leg_end ]] && ((at >= step)); }; then
    why="skipped: the killed run had no checkpoint of ttc, or had written the outputs of step $step"; return 2
  fi
  [[ $c == stage_end ]] && ((at >= step)) && note="its checkpoint is at the test's last step $step"
  echo "$c: killed at event $n (ttc's last checkpoint before event $event, the outputs of step $step; rows to $at)"
  run --resume 2>"$work/err" || { why="--resume exited $?: $(tail -3 "$work/err")"; return 1; }
  [[ ! -e $r/ttc/checkpoint.state ]] || { why="the finished run kept ttc/checkpoint.state"; return 1; }
  # (the reference's end snapshot has forces: a resume that lost them cannot match it)
  awk '/^ITEM: ATOMS/ { for (i = 1; i <= NF; ++i) if ($i == "fx") c = i - 2; next } c && $c != 0 { found = 1; exit }
       END { exit !found }' "$work/ref-$c/ttc/snapshots/ttc_6000.dump" || { why="the reference's end snapshot has no forces"; return 1; }
  diff <(cd "$work/ref-$c" && find . -type f ! -name run.lock | sort) <(cd "$r" && find . -type f ! -name run.lock | sort) >/dev/null ||
    { why="the resumed run's files are not the uninterrupted run's"; return 1; }
  while read -r f; do
    cmp -s "$work/ref-$c/$f" "$r/$f" || { why="$f differs from the uninterrupted run's${note:+ ($note)}"; return 1; }
  done < <(cd "$work/ref-$c" && find ttc prepare prepared.state -type f | sort)
  /usr/bin/python3 - "$work/ref-$c/summary.json" "$r/summary.json" > "$work/why" <<'EOF' || { why="summary.json: $(head -c 300 "$work/why")"; return 1; }
import json, re, sys
timing = re.compile(r"wall|per_s|elapsed|seconds|_s$|threads|speed")
def strip(v):
    if isinstance(v, dict):
        return {k: strip(x) for k, x in v.items() if not timing.search(k)}
    return [strip(x) for x in v] if isinstance(v, list) else v
a, b = (strip(json.load(open(p))) for p in sys.argv[1:3])
for k in sorted(set(a["tests"]["ttc"]) | set(b["tests"]["ttc"])):
    if a["tests"]["ttc"].get(k) != b["tests"]["ttc"].get(k):
        print(f"tests.ttc.{k}: {a['tests']['ttc'].get(k)!r} != {b['tests']['ttc'].get(k)!r}")
        sys.exit(1)
sys.exit(json.dumps(a, sort_keys=True) != json.dumps(b, sort_keys=True))
EOF
  [[ -z $note ]] || { why="$note"; return 1; }
}

for c in stage_end leg_end; do
  why=""
  run_case "$c"
  case $? in
    0) passed=$((passed + 1)); echo "passed: $c" ;;
    1) failed=$((failed + 1)); echo "failed: $c: $why" ;;
    *) skipped=$((skipped + 1)); echo "skipped: $c: ${why#skipped: }" ;;
  esac
done
echo "$passed passed, $failed failed, $skipped skipped"
((failed == 0)) || { echo "FAIL"; exit 1; }
((skipped == 0)) || { echo "SKIP: not every case set up what it tests"; exit 77; }
echo "PASS"
