# The trial loop and tally that the seeded fault harnesses share (sourced by test_faults.sh and test_trials.sh).
# A harness defines `kinds` (an array) and, per kind, trial_<kind>: 0 passed, 1 failed, 2 skipped (the moment or
# setting drawn did not set up what it tests: never counted as passed), with the reason in $why. Optionally
# draw_kind (sets $kind after each kind has run once; default: drawn evenly) and tally_show_skips (1: print each
# skipped trial's reason; default 1).
declare -A passed failed skipped
count=0

# Counts one trial of $1 by its exit code $2, printing a failure's reason (and a skip's, with tally_show_skips).
tally_trial() {
  local kind="$1" rc="$2"
  if ((rc == 0)); then passed[$kind]=$((${passed[$kind]:-0} + 1))
  elif ((rc == 1)); then failed[$kind]=$((${failed[$kind]:-0} + 1)); echo "failed: $kind: $why"
  else
    skipped[$kind]=$((${skipped[$kind]:-0} + 1))
    [[ ${tally_show_skips:-1} == 1 ]] && echo "skipped: $kind: ${why#skipped: }"
  fi
  return 0
}

# Runs each kind once, then kinds drawn (draw_kind, else evenly, from $RANDOM) until $1 seconds have passed.
run_trials() {
  local budget="$1" t0=$SECONDS rc
  while :; do
    if ((count < ${#kinds[@]})); then kind=${kinds[count]}
    elif declare -F draw_kind >/dev/null; then draw_kind
    else kind=${kinds[RANDOM % ${#kinds[@]}]}; fi
    ((count >= ${#kinds[@]} && SECONDS - t0 >= budget)) && break
    count=$((count + 1))
    why=""
    "trial_$kind"; rc=$?
    tally_trial "$kind" "$rc"
  done
}

# Prints the table (a row per kind of $2..., the first column $1 characters wide) and exits 1 when a trial failed or
# none ran, else prints PASS (and returns: the caller exits 0).
tally_report() {
  local width="$1" kind total_failed=0 total=0 total_passed=0
  shift
  printf "%-${width}s %6s %6s %7s\n" kind passed failed skipped
  for kind in "$@"; do
    printf "%-${width}s %6d %6d %7d\n" "$kind" "${passed[$kind]:-0}" "${failed[$kind]:-0}" "${skipped[$kind]:-0}"
    total_failed=$((total_failed + ${failed[$kind]:-0}))
    total=$((total + ${passed[$kind]:-0} + ${failed[$kind]:-0} + ${skipped[$kind]:-0}))
    total_passed=$((total_passed + ${passed[$kind]:-0}))
  done
  ((total_failed == 0)) || { echo "FAIL: $total_failed trials failed"; exit 1; }
  ((total > 0)) || { echo "FAIL: no trial ran"; exit 1; }
  # Every trial skipped: nothing was tested, which is not a pass (exit 77: ctest reports the test skipped).
  ((total_passed > 0)) || { echo "SKIP: all $total trials skipped (none set up what it tests)"; exit 77; }
  echo "PASS"
}
