#!/usr/bin/env bash
# Faults in file handling, through the binary, each trial counted passed, failed or skipped (a trial that could not
# set up what it tests - the kill did not land in the merge, no tmpfs could be mounted - is skipped, never passed):
#   merge_kill      a merge of seed shares killed (SIGKILL) at its N-th file event (tests/support/kill_at.c), once or
#                   twice, then run again: the files of an uninterrupted merge, byte for byte (run.lock's pid aside)
#   merge_full      a merge onto a full disk (a 64 KiB tmpfs, root only): exit 1 naming "No space left on device",
#                   no half-copied folder; the disk grown, merged again: the files of an uninterrupted merge
#   readonly_share  a share on a read-only mount (root) or read-only files (others): merged as any other
#   (run.lock deleted under a live run: test_trials.sh's lock_deleted)
#   lock_symlink    run.lock a symbolic link: refused, the file it names untouched
#   stage_symlink   a stage folder linked into another run: refused naming it, the other run untouched
#   pid_race        two runs started together on a folder a killed run left: the one refused names the other's pid
#   stray_checkpoint  a run killed just after marking a stage done, resumed: no checkpoint.state left
#   share_resumed   a share merged before it finished (exit 1, left out), resumed, merged again: the files of an
#                   uninterrupted merge of the finished share
# Usage: test_faults.sh CELLDEM LIBKILL_AT [SEED=1] [SECONDS=30]   (CELLDEM_VERBOSE=1: say why a trial was skipped)
set -uo pipefail
celldem="$(realpath "$1")"
kill_at="$(realpath "$2")"
seed="${3:-1}"
budget="${4:-30}"
RANDOM=$seed
work=$(mktemp -d)
mounts=()
cleanup() {
  jobs -p | xargs -r kill -9 2>/dev/null
  wait 2>/dev/null
  for m in "${mounts[@]}"; do umount "$m" 2>/dev/null; done
  chmod -R u+w "$work" 2>/dev/null
  rm -rf "$work"
}
trap cleanup EXIT
here="$(dirname "$0")"
cp "$here/small_run.json" "$work/deck.json"
grep -q '"strain":0.006' "$work/deck.json" || { echo "FAIL: small_run.json changed: adapt this test"; exit 1; }
sed 's/"strain":0.006/"strain":0.05/g' "$work/deck.json" > "$work/long.json"
source "$here/trial_tally.sh"
tally_show_skips=0
[[ -n ${CELLDEM_VERBOSE:-} ]] && tally_show_skips=1
kinds=(merge_kill merge_full readonly_share lock_symlink stage_symlink pid_race stray_checkpoint
       share_resumed)
# CELLDEM_FAULT_KINDS="merge_kill pid_race": only these kinds.
[[ -n ${CELLDEM_FAULT_KINDS:-} ]] && read -ra kinds <<< "$CELLDEM_FAULT_KINDS"
why=""
start() { "$celldem" run "$@" --quiet --threads 1 2>/dev/null & pid=$!; }
# Lists a folder's files (run.lock's content aside: a pid) as "path checksum" lines.
listing() { (cd "$1" && find . -type f ! -name run.lock -exec md5sum {} + | sort -k2; find . -name run.lock | sort); }
same_tree() {  # $1 $2: the same files, byte for byte
  diff <(listing "$1") <(listing "$2") > "$work/diff" || { why="$1 differs from $2: $(head -c 300 "$work/diff")"; return 1; }
}
wait_for() {  # $1: a file; waits for it while $pid lives (up to 20 s)
  for ((k = 0; k < 1000; ++k)); do [[ -e $1 ]] && return 0; kill -0 $pid 2>/dev/null || return 1; sleep 0.02; done
  return 1
}

trial_merge_kill() {
  local m="$work/mk" n rc kills=$((1 + RANDOM % 2)) i landed=""
  rm -rf "$m" "$work/kill.log"
  for ((i = 0; i < kills; ++i)); do
    n=$((1 + RANDOM % merge_events))
    rm -f "$work/kill.log"
    # (waited for with the shell's own messages silenced: no "Killed" line)
    { CELLDEM_KILL_AT=$n CELLDEM_KILL_LOG="$work/kill.log" LD_PRELOAD="$kill_at" \
        "$celldem" merge "$m" "$work/share1" "$work/share2" "$work/share3" >/dev/null 2>"$work/err" &
      wait $!; } 2>/dev/null
    rc=$?
    # Proof the kill landed in the merge: killed by SIGKILL at the event drawn.
    if ((rc != 137)) || ! tail -1 "$work/kill.log" | grep -q "^$n .* KILL$"; then
      ((i > 0)) && break  # (a second kill drawn past the end of what was left: the first one stands)
      why="skipped: no kill at event $n (exit $rc)"; return 2
    fi
    landed+="${landed:+, then }$(tail -1 "$work/kill.log")"
  done
  "$celldem" merge "$m" "$work/share1" "$work/share2" "$work/share3" >/dev/null 2>"$work/err"
  rc=$?
  ((rc == 0)) || { why="killed at $landed, the merge again exited $rc: $(head -c 300 "$work/err")"; return 1; }
  same_tree "$work/merged" "$m" || { why="killed at $landed: $why"; return 1; }
}

# Mounts a tmpfs of $2 at $1 (root only); 0 when mounted.
mount_tmpfs() {
  mkdir -p "$1"
  (($(id -u) == 0)) && mount -t tmpfs -o "size=$2" none "$1" 2>/dev/null || return 1
  mounts+=("$1")
}
trial_merge_full() {
  local d="$work/full" rc
  if ! mountpoint -q "$d" 2>/dev/null; then
    mount_tmpfs "$d" 64k || { why="skipped: cannot mount a tmpfs (needs root)"; return 2; }
  fi
  rm -rf "${d:?}"/*
  mount -o remount,size=64k "$d" 2>/dev/null || { why="skipped: cannot resize the tmpfs"; return 2; }
  "$celldem" merge "$d/m" "$work/share1" "$work/share2" "$work/share3" >/dev/null 2>"$work/err"
  rc=$?
  ((rc != 0)) || { why="skipped: the merge fitted in 64 KiB"; return 2; }
  ((rc == 1)) || { why="a full disk: exit $rc, expected 1: $(head -c 300 "$work/err")"; return 1; }
  grep -q "No space left on device" "$work/err" || { why="a full disk is not named: $(head -c 300 "$work/err")"; return 1; }
  grep -q "$d/m/" "$work/err" || { why="the message names no file: $(head -c 300 "$work/err")"; return 1; }
  ls -d "$d"/m/.*merge-partial "$d"/m/seed-* 2>/dev/null | grep -q . && { why="a failed merge left $(ls -a "$d/m" | tr '\n' ' ')"; return 1; }
  mount -o remount,size=64m "$d" || { why="skipped: cannot grow the tmpfs"; return 2; }
  "$celldem" merge "$d/m" "$work/share1" "$work/share2" "$work/share3" >/dev/null 2>"$work/err"
  rc=$?
  ((rc == 0)) || { why="after a full disk, the merge exited $rc: $(head -c 300 "$work/err")"; return 1; }
  same_tree "$work/merged" "$d/m"
}

trial_readonly_share() {
  local ro="$work/ro" m="$work/rm" rc
  rm -rf "$m"
  if ! mountpoint -q "$ro" 2>/dev/null; then
    rm -rf "$ro"
    if (($(id -u) == 0)); then
      mkdir -p "$ro"
      { mount --bind "$work/share1" "$ro" && mounts+=("$ro") && mount -o remount,bind,ro "$ro"; } 2>/dev/null ||
        { why="skipped: cannot mount read-only"; return 2; }
    else
      cp -r "$work/share1" "$ro" && chmod -R a-w "$ro"
    fi
  fi
  # Proof the share is read-only to this process.
  if touch "$ro/probe" 2>/dev/null || touch "$ro/seed-1/probe" 2>/dev/null; then
    rm -f "$ro/probe" "$ro/seed-1/probe"; why="skipped: the share could be written"; return 2
  fi
  "$celldem" merge "$m" "$ro" "$work/share2" "$work/share3" >/dev/null 2>"$work/err"
  rc=$?
  ((rc == 0)) || { why="a read-only share: exit $rc: $(head -c 300 "$work/err")"; return 1; }
  same_tree "$work/merged" "$m"
}

trial_lock_symlink() {
  local d="$work/ls" rc what
  rm -rf "$d"
  mkdir -p "$d"
  echo "not a pid" > "$work/victim"
  ln -s "$work/victim" "$d/run.lock"
  if ((RANDOM % 2)); then what="run"; "$celldem" run "$work/deck.json" --out "$d" --quiet 2>"$work/err"
  else what="merge"; "$celldem" merge "$d" "$work/share1" >/dev/null 2>"$work/err"; fi
  rc=$?
  [[ $(cat "$work/victim") == "not a pid" ]] || { why="$what wrote through run.lock: $(cat "$work/victim")"; return 1; }
  ((rc == 2)) || { why="$what with a linked run.lock exited $rc, expected 2"; return 1; }
  grep -q "symbolic link" "$work/err" || { why="$what: $(head -c 300 "$work/err")"; return 1; }
}

trial_stage_symlink() {
  local d="$work/ss" other="$work/other" rc what before
  rm -rf "$d" "$other"
  cp -r "$work/ref" "$other"
  before=$(listing "$other")
  case $((RANDOM % 3)) in
    0) what="a fresh run"; mkdir -p "$d"; ln -s "$other/ttc" "$d/ttc"
       "$celldem" run "$work/deck.json" --out "$d" --quiet --threads 1 2>"$work/err" ;;
    1) what="--force"; cp -r "$work/ref" "$d"; rm -rf "$d/ttc"; ln -s "$other/ttc" "$d/ttc"
       "$celldem" run "$work/deck.json" --out "$d" --force --quiet --threads 1 2>"$work/err" ;;
    2) what="--resume"; cp -r "$work/ref" "$d"; rm -rf "$d/psc"; ln -s "$other/psc" "$d/psc"
       /usr/bin/python3 -c 'import json, sys; p = json.load(open(sys.argv[1])); p["completed"].remove("psc")
json.dump(p, open(sys.argv[1], "w"))' "$d/progress.json"
       "$celldem" run "$work/deck.json" --out "$d" --resume --quiet --threads 1 2>"$work/err" ;;
  esac
  rc=$?
  [[ $(listing "$other") == "$before" ]] || { why="$what wrote into the other run through the link"; return 1; }
  ((rc == 2)) || { why="$what through a linked stage folder exited $rc, expected 2: $(head -c 300 "$work/err")"; return 1; }
  grep -q "$d/.* is a symbolic link.*outside the run folder" "$work/err" || { why="$what: $(head -c 300 "$work/err")"; return 1; }
}

trial_pid_race() {  # on a folder whose run.lock holds a dead pid, as a killed run leaves it
  local d="$work/pr" a b rc_a=none rc_b=none k dead
  rm -rf "$d"
  mkdir -p "$d"
  true & dead=$!
  wait $dead
  echo "$dead" > "$d/run.lock"
  "$celldem" run "$work/long.json" --out "$d" --quiet --threads 1 2>"$work/err_a" & a=$!
  sleep "0.0$((RANDOM % 3))"
  "$celldem" run "$work/long.json" --out "$d" --quiet --threads 1 2>"$work/err_b" & b=$!
  for ((k = 0; k < 500; ++k)); do
    kill -0 $a 2>/dev/null || { wait $a; rc_a=$?; break; }
    kill -0 $b 2>/dev/null || { wait $b; rc_b=$?; break; }
    sleep 0.02
  done
  kill -TERM $a $b 2>/dev/null; wait $a $b 2>/dev/null
  if [[ $rc_a == 2 ]]; then grep -q "pid $b[,)]" "$work/err_a" || { why="refused, told: $(cat "$work/err_a") (holder $b)"; return 1; }
  elif [[ $rc_b == 2 ]]; then grep -q "pid $a[,)]" "$work/err_b" || { why="refused, told: $(cat "$work/err_b") (holder $a)"; return 1; }
  else why="skipped: neither refused (exits $rc_a, $rc_b)"; return 2; fi
}

trial_stray_checkpoint() {
  local d="$work/sc" n rc
  rm -rf "$d"
  # The event at which the run removes ttc's checkpoint when the stage is marked done.
  n=$(grep "unlink $d/ttc/checkpoint.state\$" "$work/run.log" | tail -1 | cut -d' ' -f1)
  [[ -n $n ]] || { why="skipped: no removal of ttc's checkpoint listed"; return 2; }
  { CELLDEM_KILL_AT=$n CELLDEM_KILL_WHEN=before CELLDEM_KILL_LOG="$work/sc.log" LD_PRELOAD="$kill_at" \
      "$celldem" run "$work/deck.json" --out "$d" --quiet --threads 1 2>/dev/null &
    wait $!; } 2>/dev/null
  rc=$?
  if ((rc != 137)) || ! tail -1 "$work/sc.log" | grep -q "checkpoint.state KILL$"; then
    rm -f "$work/sc.log"; why="skipped: the kill did not land at the checkpoint's removal (exit $rc)"; return 2
  fi
  rm -f "$work/sc.log"
  [[ -f $d/ttc/checkpoint.state ]] || { why="skipped: no checkpoint was left by the kill"; return 2; }
  "$celldem" run "$work/deck.json" --out "$d" --resume --quiet --threads 1 2>"$work/err" ||
    { why="the resume exited $?: $(head -c 300 "$work/err")"; return 1; }
  for s in prepare ttc psc; do [[ ! -f "$d/$s/checkpoint.state" ]] || { why="a finished run kept $s/checkpoint.state"; return 1; }; done
  for f in ttc/series.csv psc/series.csv ttc/final.state psc/final.state; do
    cmp -s "$work/ref/$f" "$d/$f" || { why="$f differs from the uninterrupted run"; return 1; }
  done
}

trial_share_resumed() {
  local s4="$work/share4" m="$work/sr" rc
  rm -rf "$s4" "$m" "$work/merged14"
  start "$work/deck.json" --seeds 4 --out "$s4"
  wait_for "$s4/seed-4/ttc/series.csv" || { wait $pid; why="skipped: the share ended first"; return 2; }
  kill -KILL $pid; wait $pid 2>/dev/null
  "$celldem" merge "$m" "$work/share1" "$s4" >/dev/null 2>"$work/err"
  rc=$?
  # Proof: the share was merged while not complete.
  ((rc == 1)) && grep -q "not complete" "$work/err" || { why="skipped: the stopped share merged with exit $rc"; return 2; }
  "$celldem" run "$work/deck.json" --seeds 4 --out "$s4" --resume --quiet --threads 1 >/dev/null 2>"$work/err" ||
    { why="the share's resume exited $?: $(head -c 300 "$work/err")"; return 1; }
  "$celldem" merge "$m" "$work/share1" "$s4" >/dev/null 2>"$work/err"
  rc=$?
  ((rc == 0)) || { why="merged again once the share finished: exit $rc: $(head -c 300 "$work/err")"; return 1; }
  "$celldem" merge "$work/merged14" "$work/share1" "$s4" >/dev/null 2>&1 || { why="the reference merge failed"; return 1; }
  same_tree "$work/merged14" "$m"
}

# The references: a run (its file events listed, at the folder the stray_checkpoint trial uses), three seed shares
# and their uninterrupted merge (its file events counted).
CELLDEM_KILL_LOG="$work/run.log" LD_PRELOAD="$kill_at" \
  "$celldem" run "$work/deck.json" --out "$work/sc" --quiet --threads 1 || { echo "FAIL: reference run"; exit 1; }
mv "$work/sc" "$work/ref"
for s in 1 2 3; do
  "$celldem" run "$work/deck.json" --seeds $s --out "$work/share$s" --quiet --threads 1 >/dev/null || { echo "FAIL: share $s"; exit 1; }
done
CELLDEM_KILL_LOG="$work/merge.log" LD_PRELOAD="$kill_at" \
  "$celldem" merge "$work/merged" "$work/share1" "$work/share2" "$work/share3" >/dev/null || { echo "FAIL: reference merge"; exit 1; }
merge_events=$(wc -l < "$work/merge.log" 2>/dev/null || echo 0)
((merge_events > 0)) || { echo "FAIL: $kill_at listed no file event of the merge"; exit 1; }
echo "references: a merge of 3 seed shares makes $merge_events file events (seed $seed, budget ${budget}s)"

# (after one of each, a merge killed is drawn as often as all the others together: the widest space of moments)
draw_kind() {
  if ((RANDOM % 2)) && [[ " ${kinds[*]} " == *" merge_kill "* ]]; then kind=merge_kill
  else kind=${kinds[RANDOM % ${#kinds[@]}]}; fi
}
run_trials "$budget"
tally_report 18 "${kinds[@]}"
