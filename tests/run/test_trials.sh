#!/usr/bin/env bash
# Seeded, time-bounded trials of a batch operator's misuse of run folders, through the binary: SIGKILL and
# SIGTERM at random moments then --resume (compared byte for byte with an uninterrupted run), a series.csv
# edited, cut, deleted or extended behind a checkpoint, two processes on one folder, a rate check and probes
# resumed from a checkpoint, shares of foreign decks or kinds merged. Each kind runs at least once, then
# kinds are drawn (from SEED) until SECONDS have passed. Prints a table of trials per kind; fails if any
# trial failed. (test_kill_resume.sh: kills over a whole run and the report tools.)
# Usage: test_trials.sh CELLDEM [SEED=1] [SECONDS=90]
set -uo pipefail
celldem="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"  # absolute: some trials run from another folder
seed="${2:-1}"
budget="${3:-90}"
RANDOM=$seed
work=$(mktemp -d)
trap 'jobs -p | xargs -r kill -9 2>/dev/null; rm -rf "$work"' EXIT
here="$(dirname "$0")"
cp "$here/small_run.json" "$work/deck.json"
grep -q '"strain":0.006' "$work/deck.json" || { echo "FAIL: small_run.json changed: adapt this test"; exit 1; }
source "$here/trial_tally.sh"
kinds=(continue_command kill_resume series_extra series_tampered finished_tampered two_processes lock_deleted branch_resumed probe_stop probe_shares foreign_share)
why=""
run_quiet() { "$celldem" run "$@" --quiet --threads 1; }
# Starts a run in the background: $pid is celldem's own (a function run with & would be a subshell's).
start() { "$celldem" run "$@" --quiet --threads 1 2>/dev/null & pid=$!; }
finals="prepare/series.csv ttc/series.csv psc/series.csv prepared.state ttc/final.state psc/final.state"
same_as_ref() {  # $1: run folder; every final file byte-identical to the uninterrupted run's
  for f in $finals; do cmp -s "$work/ref/$f" "$1/$f" || { why="$f differs from the uninterrupted run"; return 1; }; done
  for s in prepare ttc psc; do [[ ! -f "$1/$s/checkpoint.state" ]] || { why="a finished run kept $s/checkpoint.state"; return 1; }; done
}
# Starts a run into $1 (run arguments after the first three) and stops it with signal $2 once the file $3
# exists (FILE:N: holds N lines), a random moment later: 0 when it was stopped before the end.
stop_when() {
  local d="$1" signal="$2" file="$3"
  shift 3
  rm -rf "$d"
  local pid
  start "$@" --out "$d"
  local lines=0
  [[ $file == *:* ]] && lines=${file##*:} file=${file%:*}
  for ((k = 0; k < 1000; ++k)); do
    [[ -e $file && $(wc -l < "$file") -ge $lines ]] && break
    kill -0 $pid 2>/dev/null || break
    sleep 0.02
  done
  sleep "0.$((RANDOM % 3))"
  kill -"$signal" $pid 2>/dev/null
  wait $pid 2>/dev/null
  (($? != 0))
}
# Resumes until the run ends (at most 5 times): the last exit code.
resume_to_end() {
  local rc=1
  for ((k = 0; k < 5; ++k)); do "$celldem" run "$@" --resume --quiet --threads 1 2>"$work/err"; rc=$?; ((rc == 130)) || break; done
  return $rc
}

trial_kill_resume() {  # 1 to 3 SIGKILLs or SIGTERMs at random moments, each followed by --resume
  local d="$work/kr" n=$((1 + RANDOM % 3)) pid rc
  rm -rf "$d"
  start "$work/deck.json" --out "$d"
  for ((i = 0; i < n; ++i)); do
    sleep "$(echo "scale=3; $ref_seconds * $((RANDOM % 1000)) / 1000 / $n" | bc)"  # (% in the shell: bc's is 0 at scale=3)
    kill -0 $pid 2>/dev/null || break
    if ((RANDOM % 2)); then kill -TERM $pid; else kill -KILL $pid; fi
    wait $pid 2>/dev/null
    if [[ -f "$d/progress.json" ]]; then start "$work/deck.json" --out "$d" --resume
    else start "$work/deck.json" --out "$d" --force; fi
  done
  wait $pid || { why="the last run exited $?"; return 1; }
  same_as_ref "$d"
}

trial_series_extra() {  # rows after the checkpoint's (a killed run's, or appended): cut, and the run ends as the reference
  local d="$work/se"
  stop_when "$d" KILL "$d/ttc/checkpoint.state" "$work/deck.json" || { why="skipped: finished first"; return 2; }
  # (only behind a checkpoint: a stage that finished before the kill keeps no proof of its series yet)
  [[ -f $d/ttc/checkpoint.state ]] || { why="skipped: ttc finished first"; return 2; }
  [[ -f $d/ttc/series.csv ]] && tail -1 "$d/ttc/series.csv" | sed 's/^[0-9]*/99999999/' >> "$d/ttc/series.csv"
  resume_to_end "$work/deck.json" --out "$d" || { why="resume exited $?: $(tail -1 "$work/err")"; return 1; }
  same_as_ref "$d"
}

trial_series_tampered() {  # a series that no longer holds what the checkpoint recorded: refused, exit 2, naming it
  local d="$work/st" variant=$((RANDOM % 5)) f
  stop_when "$d" TERM "$d/ttc/checkpoint.state" "$work/deck.json" || { why="skipped: finished first"; return 2; }
  f="$d/ttc/series.csv"
  [[ -f $d/ttc/checkpoint.state && $(wc -l < "$f") -ge 4 ]] || { why="skipped: no checkpoint with rows"; return 2; }
  case $variant in
    0) awk -F, -v OFS=, 'NR == 3 { $5 = ($5 == 0 ? 1 : $5 * 1.01) } 1' "$f" > "$f.new" && mv "$f.new" "$f"
       variant="edited value" ;;
    1) sed -i '3,$d' "$f"; variant="deleted rows" ;;
    2) rm "$f"; variant="deleted file" ;;
    3) sed -i '1s/s11/x11/' "$f"; variant="renamed header" ;;
    4) sed -i '3p' "$f"; variant="repeated row" ;;
  esac
  "$celldem" run "$work/deck.json" --out "$d" --resume --quiet --threads 1 2>"$work/err"; local rc=$?
  ((rc == 2)) || { why="$variant: --resume exited $rc, expected 2"; return 1; }
  grep -q "ttc/series.csv" "$work/err" || { why="$variant: the message does not name ttc/series.csv: $(cat "$work/err")"; return 1; }
}

trial_finished_tampered() {  # a finished stage's files or results changed behind a stopped run: refused, exit 2, naming it
  local d="$work/ft" variant=$((RANDOM % 6)) f
  stop_when "$d" TERM "$d/psc/checkpoint.state" "$work/deck.json" || { why="skipped: finished first"; return 2; }
  [[ -f $d/psc/checkpoint.state && -f $d/ttc/final.state ]] || { why="skipped: not stopped inside psc"; return 2; }
  case $variant in
    0) f=ttc/series.csv; tail -1 "$d/$f" | sed 's/^[0-9]*/99999999/' >> "$d/$f"; variant="a row appended" ;;
    1) f=ttc/series.csv; awk -F, -v OFS=, 'NR == 3 { $5 = ($5 == 0 ? 1 : $5 * 1.01) } 1' "$d/$f" > "$d/x" && mv "$d/x" "$d/$f"
       variant="a value edited" ;;
    2) f=ttc/series.csv; sed -i '$d' "$d/$f"; variant="the last row cut" ;;
    3) f=summary.json; rm "$d/$f"; variant="summary.json deleted" ;;
    4) f=prepared.state; cp "$d/ttc/final.state" "$d/$f"; variant="prepared.state replaced" ;;
    5) f=ttc/final.state; rm "$d/$f"; variant="a final state deleted" ;;
  esac
  "$celldem" run "$work/deck.json" --out "$d" --resume --quiet --threads 1 2>"$work/err"; local rc=$?
  ((rc == 2)) || { why="$variant: --resume exited $rc, expected 2"; return 1; }
  grep -q "$f" "$work/err" || { why="$variant: the message does not name $f: $(cat "$work/err")"; return 1; }
}

trial_continue_command() {  # SIGINT under --tolerance and --seeds: the printed "Continue with" command works as printed
  local d="$work/c c" pid rc line
  rm -rf "$d"
  (cd "$work" && exec "$celldem" run deck.json --out "c c" --tolerance 1 --seeds 1-2 --threads 1 --quiet 2>"$work/cerr") &
  pid=$!
  for ((k = 0; k < 500; ++k)); do [[ -f $d/seed-1/prepare/series.csv ]] && break; sleep 0.02; done
  sleep "0.$((RANDOM % 5))"
  kill -INT $pid 2>/dev/null
  wait $pid; rc=$?
  ((rc == 130)) || { why="skipped: the run was not stopped (exit $rc)"; return 2; }
  line=$(grep -o "Continue with: .*" "$work/cerr" | sed 's/^Continue with: celldem //')
  [[ -n $line ]] || { why="no 'Continue with' line: $(tail -1 "$work/cerr")"; return 1; }
  (cd "$work" && eval "\"\$celldem\" $line") >/dev/null 2>"$work/err" || { why="'celldem $line' exited $?: $(tail -1 "$work/err")"; return 1; }
  [[ -f $d/ensemble.json ]] || { why="'celldem $line' wrote no ensemble.json"; return 1; }
}

trial_two_processes() {  # a second process on a live folder: refused with exit 2 naming the holder, nothing deleted
  local d="$work/tp" pid rc what lock_gone="${1:-0}"
  rm -rf "$d"
  start "$work/long.json" --out "$d"
  for ((k = 0; k < 500; ++k)); do [[ -f $d/prepare/series.csv ]] && break; sleep 0.02; done
  ((lock_gone)) && rm -f "$d/run.lock"  # the folder itself stays locked
  case $((RANDOM % 4)) in
    0) what="--resume"; timeout 30 "$celldem" run "$work/long.json" --out "$d" --resume --quiet 2>"$work/err" ;;
    1) what="--force"; timeout 30 "$celldem" run "$work/long.json" --out "$d" --force --quiet 2>"$work/err" ;;
    2) what="a fresh run"; timeout 30 "$celldem" run "$work/long.json" --out "$d" --quiet 2>"$work/err" ;;
    3) what="merge"; timeout 30 "$celldem" merge "$d" 2>"$work/err" ;;
  esac
  rc=$?
  kill -0 $pid 2>/dev/null || { wait $pid; why="skipped: the first run ended first"; return 2; }
  [[ -f $d/progress.json && -f $d/prepare/series.csv ]] || { kill -9 $pid; why="$what deleted the live run's files"; return 1; }
  kill -TERM $pid; wait $pid
  ((rc == 2)) || { why="$what on a live folder exited $rc, expected 2 (run.lock deleted: $lock_gone)"; return 1; }
  grep -q "pid $pid" "$work/err" || { why="$what: the refusal does not name the holder (pid $pid): $(cat "$work/err")"; return 1; }
  return 0
}

trial_lock_deleted() { trial_two_processes 1; }  # the same, with run.lock deleted under the live run

trial_branch_resumed() {  # a rate check whose test was resumed: its rungs and twins start from a state with forces
  local d="$work/br" f
  # Stopped late in ttc, so that the test resumes from a checkpoint before its check runs.
  stop_when "$d" TERM "$d/ttc/series.csv:11" "$work/deck.json" --verify-rate ||
    { why="skipped: finished first"; return 2; }
  resume_to_end "$work/deck.json" --verify-rate --out "$d" || { why="resume exited $?: $(tail -1 "$work/err")"; return 1; }
  ls "$d"/*/verify/rung-1/series.csv >/dev/null 2>&1 || { why="no verify/rung-1/series.csv after the resume"; return 1; }
  # Each starts where its test started: its first row's stresses are the test's (b at an isotropic start is nan).
  for f in "$d"/*/verify/*/series.csv; do
    [[ -f $f ]] || continue
    awk -F, 'FNR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i } FNR == 2 { r[FILENAME] = $c["s11"] "," $c["s22"] "," $c["s33"] }
      END { for (k in r) { if (seen && r[k] != first) exit 1; first = r[k]; seen = 1; if (first ~ /^0,|nan/) exit 1 } }' \
      "$f" "${f%/verify/*}/series.csv" ||
      { why="$f: its first row's stresses are not its test's: $(sed -n 2p "$f" | cut -c1-80)"; return 1; }
  done
}

trial_probe_stop() {  # probes stopped after their points and resumed: every point's probes ran
  local d="$work/ps"
  stop_when "$d" TERM "$d/ttc/series.csv" "$work/probes.json" || { why="skipped: finished first"; return 2; }
  resume_to_end "$work/probes.json" --out "$d" || { why="resume exited $?: $(tail -1 "$work/err")"; return 1; }
  /usr/bin/python3 - "$d/summary.json" <<'EOF' || { why="$(cat "$work/why")"; return 1; }
import json, sys
s = json.load(open(sys.argv[1]))
bad = [(t, p, v.get("status")) for t, r in s["tests"].items() for p, v in r.get("probes", {}).get("points", {}).items()
       if v.get("status") != "ran"]
if bad and not s.get("warnings"):
    open(sys.argv[1].replace("summary.json", "../why"), "w").write(f"points not run and no warning: {bad}")
    sys.exit(1)
EOF
  [[ -z $(find "$d" -name '*.tmp') ]] || { why="temporary files left"; return 1; }
  for t in ttc psc; do
    cmp -s "$work/probes_ref/$t/probes/probes.csv" "$d/$t/probes/probes.csv" ||
      { why="$t/probes/probes.csv differs from the uninterrupted run's"; return 1; }
  done
}

trial_probe_shares() {  # the README's job array (K = i * N + 1, --probes K-(K+N-1)) merged: the whole run's tables
  local n=$((2 + RANDOM % 3)) i k rc
  rm -rf "$work"/pshare-*
  for ((i = 0; i * n < 8; ++i)); do
    k=$((i * n + 1))
    run_quiet "$work/probes.json" --probes $k-$((k + n - 1)) --out "$work/pshare-$i" 2>"$work/err" ||
      { why="share $k-$((k + n - 1)) exited $?: $(tail -1 "$work/err")"; return 1; }
  done
  "$celldem" merge "$work/pshare-0" $(ls -d "$work"/pshare-* | tail -n +2) >/dev/null 2>"$work/err" ||
    { why="merge exited $?: $(tail -1 "$work/err")"; return 1; }
  for t in ttc psc; do
    cmp -s "$work/probes_ref/$t/probes/probes.csv" "$work/pshare-0/$t/probes/probes.csv" ||
      { why="shares of $n: the merged $t/probes/probes.csv differs from the whole run's"; return 1; }
  done
  "$celldem" run "$work/probes.json" --probes 9-12 --out "$work/pshare-x" --quiet 2>"$work/err"; rc=$?
  ((rc == 2)) || { why="--probes 9-12 (the deck has 8) exited $rc, expected 2"; return 1; }
}

trial_foreign_share() {  # shares of another deck or kind: merge refuses, exit 2, copying nothing
  local variant=$((RANDOM % 2)) rc
  rm -rf "$work/fs_into"
  cp -r "$work/share1" "$work/fs_into"
  if ((variant == 0)); then
    "$celldem" merge "$work/fs_into" "$work/share2_kn" >/dev/null 2>"$work/err"; rc=$?; variant="a seed share of another kn"
    [[ ! -d $work/fs_into/seed-2 ]] || { why="$variant: seed-2 copied"; return 1; }
  else
    cp -r "$work/probes_ref" "$work/fs_into_p"
    "$celldem" merge "$work/fs_into_p" "$work/share1" >/dev/null 2>"$work/err"; rc=$?; variant="a seed share into a probes run"
    [[ ! -d $work/fs_into_p/seed-1 && ! -f $work/fs_into_p/ensemble.json ]] || { rm -rf "$work/fs_into_p"; why="$variant: copied"; return 1; }
    rm -rf "$work/fs_into_p"
  fi
  ((rc == 2)) || { why="$variant: merge exited $rc, expected 2"; return 1; }
}

# Bad input a new user gives: exit 2 and a message that names the cause (each case one trial of kind "messages").
expect_refusal() {  # $1: what; $2: a word the message must hold; the rest: the command
  local what="$1" word="$2" rc
  shift 2
  "$@" >/dev/null 2>"$work/err"; rc=$?
  if ((rc == 2)) && grep -qi -- "$word" "$work/err"; then passed[messages]=$((${passed[messages]:-0} + 1))
  else failed[messages]=$((${failed[messages]:-0} + 1)); echo "failed: messages: $what: exit $rc: $(head -c 300 "$work/err")"; fi
}
check_messages() {
  touch "$work/a_file"
  expect_refusal "--out naming a file" "not a folder" "$celldem" run "$work/deck.json" --out "$work/a_file" --quiet
  expect_refusal "--out under a file" "is a file, not a folder" "$celldem" run "$work/deck.json" --out "$work/a_file/run" --quiet
  expect_refusal "--out /dev/full" "not a folder" "$celldem" run "$work/deck.json" --out /dev/full --quiet
  expect_refusal "--seeds 3-1" "K <= L" "$celldem" run "$work/deck.json" --seeds 3-1 --out "$work/m" --quiet
  expect_refusal "--seeds 1-100000" "at most" "$celldem" run "$work/deck.json" --seeds 1-100000 --out "$work/m" --quiet
  expect_refusal "--verify-rate-factor beyond 1" "verify-rate-factor" \
    "$celldem" run "$work/deck.json" --verify-rate --verify-rate-factor 1.5 --out "$work/m" --quiet
  mkdir -p "$work/a_folder.state"
  sed -z 's/"prepare":{[^}]*}},/"initial_state":"a_folder.state",/' "$work/deck.json" > "$work/dir_state.json"
  expect_refusal "an initial_state that is a folder" "is a folder" "$celldem" check "$work/dir_state.json"
  sed 's/"magnitudes":\[2000\]/"magnitudes":[1e9]/' "$work/probes.json" > "$work/huge.json"
  expect_refusal "a 1 GPa stress probe" "confining stress" "$celldem" check "$work/huge.json"
  sed 's/"at_e1":\[0.002\]/"at_e1":[0.002,0.5]/' "$work/probes.json" > "$work/far.json"
  "$celldem" check "$work/far.json" >/dev/null 2>"$work/err"
  if grep -q "beyond the test's end" "$work/err"; then passed[messages]=$((${passed[messages]:-0} + 1))
  else failed[messages]=$((${failed[messages]:-0} + 1)); echo "failed: messages: a probe point beyond the test's end is not warned of"; fi
}

# The uninterrupted references.
start=$(date +%s.%N)
run_quiet "$work/deck.json" --out "$work/ref" || { echo "FAIL: reference run"; exit 1; }
ref_seconds=$(echo "$(date +%s.%N) - $start" | bc)
sed 's/"strain":0.006/"strain":0.05/g' "$work/deck.json" > "$work/long.json"
# Probes at e1 = 0.002 and the peak of each test, two small stress probes each: 8 probes, numbered 1-8.
sed 's/"output_interval":250}/"output_interval":250,"probes":{"at_e1":[0.002],"at":["peak"],"kind":"stress","plane":"rendulic","directions":2,"magnitudes":[2000],"steps":300,"hold_steps":100}}/g' \
  "$work/deck.json" > "$work/probes.json"
run_quiet "$work/probes.json" --out "$work/probes_ref" 2>"$work/err" || { cat "$work/err"; echo "FAIL: probes reference run"; exit 1; }
run_quiet "$work/deck.json" --seeds 1 --out "$work/share1" >/dev/null || { echo "FAIL: seed share"; exit 1; }
sed 's/"kn":1e6/"kn":2e6/' "$work/deck.json" > "$work/kn.json"
run_quiet "$work/kn.json" --seeds 2 --out "$work/share2_kn" >/dev/null || { echo "FAIL: seed share (kn)"; exit 1; }
echo "references: ${ref_seconds}s (seed $seed, budget ${budget}s)"
check_messages

run_trials "$budget"
tally_report 16 "${kinds[@]}" messages
