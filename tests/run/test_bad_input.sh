#!/usr/bin/env bash
# Hostile command lines and decks are refused before any work: exit 2 and a message naming the option or the
# key, no run folder. NaN, inf and overflowing numbers, empty values (a batch script's unset variable), a
# tolerance that is not a positive number of floors, bad rungs of the rate ladder, and `check` refusing what `run`
# refuses in a program's legs.
# Usage: test_bad_input.sh CELLDEM
set -uo pipefail
celldem="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
deck="$(dirname "$0")/small_run.json"

# refused WHAT NEEDLE ARGS...: exit 2, NEEDLE on stderr, no run folder.
refused() {
  local what="$1" needle="$2"
  shift 2
  "$celldem" "$@" > "$work/out" 2> "$work/err"
  local rc=$?
  [[ $rc -eq 2 ]] || { cat "$work/err"; fail "$what: exit code $rc, expected 2"; }
  grep -qF -- "$needle" "$work/err" || { cat "$work/err"; fail "$what: the message does not name '$needle'"; }
  [[ ! -e $work/run ]] || fail "$what: a run folder was made"
  echo "ok: $what -> $(head -1 "$work/err")"
}

run=(run "$deck" --out "$work/run" --quiet --threads 1)
# (the --option=value form: CLI11 reads a lone -inf as an option; a range check may name inf first, never NaN)
for bad in nan NaN inf -inf 1e400; do
  finite="is not a finite number"
  [[ $bad == [nN]a[nN] ]] || finite=""
  refused "--verify-rate-factor $bad" "--verify-rate-factor: ${finite:+$bad $finite}" "${run[@]}" --verify-rate "--verify-rate-factor=$bad"
  refused "--progress-interval $bad" "--progress-interval: ${finite:+$bad $finite}" "${run[@]}" "--progress-interval=$bad"
  refused "--tolerance $bad" "--tolerance: $bad is not a finite number" "${run[@]}" "--tolerance=$bad"
  refused "plan --tolerance $bad" "--tolerance: $bad is not a finite number" plan "$deck" "--tolerance=$bad"
done
# Empty values: refused, naming the option (CLI11 read '' as 0 or as "not given"); an option's own check may
# come first (the ranges of --verify-rate-factor, --progress-interval and --threads, --floors' existing file).
for option in --tolerance --seeds --probes; do
  refused "$option ''" "$option: an empty value" "${run[@]}" --verify-rate "$option" ""
done
for option in --verify-rate-factor --verify-rate-rungs --verify-twins --progress-interval; do
  refused "$option ''" "$option: " "${run[@]}" --verify-rate "$option" ""
done
refused "--threads ''" "--threads:" run "$deck" --out "$work/run" --quiet --threads ""
refused "--floors ''" "--floors:" "${run[@]}" --verify-rate --floors ""
refused "--out ''" "--out: an empty value" run "$deck" --out "" --quiet
refused "--tolerance=" "--tolerance: " "${run[@]}" --tolerance=
refused "plan --tolerance ''" "--tolerance: an empty value" plan "$deck" --tolerance ""
# Not a positive number of floors (any positive T is a rate from the bias laws: no upper bound).
refused "--tolerance 0" "--tolerance: 0: expected a positive number of noise floors" "${run[@]}" --tolerance 0
# The ladder's rungs: a list of at least two rates in [0.001, 0.999]; twins at least 2.
for bad in 0.5 0.5,abc 0.5,0.5 0.5,1 ,; do
  refused "--verify-rate-rungs $bad" "--verify-rate-rungs: " "${run[@]}" --verify-rate --verify-rate-rungs "$bad"
done
refused "--verify-twins 1" "--verify-twins: " "${run[@]}" --verify-rate --verify-twins 1
refused "--verify-rate-rungs with --verify-rate-factor" "exclude each other" "${run[@]}" --verify-rate \
  --verify-rate-rungs 0.5,0.25 --verify-rate-factor 0.5

# `check` refuses what `run` refuses in a program's legs: a leg driven away from its end strain, a stress end
# that the leg's own servo keeps it from.
# The deck's ttc test as a program of two legs: to e1 = 0.4 %, then LEG2.
leg1='{"axes":{"x1":{"strain_increment":1e-6},"x2":{"stress":1e5},"x3":{"stress":1e5}},"end":{"axis":"x1","strain":0.004}}'
sed "s/\"axes\":{\"x1\":{\"strain_increment\":1e-6},\"x2\":{\"stress\":1e5},\"x3\":{\"stress\":1e5}},/\"legs\":[$leg1,/;
     s/\"end\":{\"axis\":\"x1\",\"strain\":0.006},\"output_interval\":250},/LEG2],\"output_interval\":250},/" \
  "$deck" > "$work/legs.json"
grep -q 'LEG2]' "$work/legs.json" && grep -q '"legs":\[' "$work/legs.json" || fail "small_run.json changed: adapt this test"
program() {  # program NAME LEG2
  sed "s/LEG2/$2/" "$work/legs.json" > "$work/$1.json"
}
program behind '{"axes":{"x1":{"strain_increment":1e-6},"x2":{"stress":1e5},"x3":{"stress":1e5}},"end":{"axis":"x1","strain":0.002}}'
program servo '{"axes":{"x1":{"strain_increment":0},"x2":{"stress":1e5},"x3":{"stress":1e5}},"end":{"axis":"x2","stress":2e5,"max_steps":5000}}'
program good '{"axes":{"x1":{"strain_increment":-1e-6},"x2":{"stress":1e5},"x3":{"stress":1e5}},"end":{"axis":"x1","strain":0.002}}'
"$celldem" check "$work/good.json" > "$work/out" 2> "$work/err" || { cat "$work/err"; fail "the unloading program is refused"; }
second="tests[0].legs (leg 1 of the program, repeats unrolled)"
for cmd in check run; do
  args=("$cmd")
  [[ $cmd == run ]] && args=(run --out "$work/run" --quiet)
  refused "$cmd: a leg behind its drive" "$second: end.strain: the end axis is not strained towards this value" \
    "${args[@]}" "$work/behind.json"
  refused "$cmd: an end the servo keeps the leg from" "$second: end.stress: the leg holds axis x2 at 100000 Pa" \
    "${args[@]}" "$work/servo.json"
done
# The rate check beside an adaptive rate: the slower run would set its own rate, so the pair is refused (on the
# command line by run, as a test's verify_rate key by check and run alike), naming adaptive_rate.
/usr/bin/python3 - "$deck" "$work" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["tests"][0]["adaptive_rate"] = {}
json.dump(d, open(sys.argv[2] + "/adaptive.json", "w"))
d["tests"][0]["verify_rate"] = {}
json.dump(d, open(sys.argv[2] + "/adaptive_key.json", "w"))
EOF
"$celldem" check "$work/adaptive.json" > "$work/out" 2> "$work/err" || { cat "$work/err"; fail "an adaptive test is refused"; }
refused "run --verify-rate beside an adaptive rate" "--verify-rate with tests[].adaptive_rate" \
  run "$work/adaptive.json" --out "$work/run" --quiet --threads 1 --verify-rate
refused "check: a test's verify_rate beside its adaptive rate" "tests[].verify_rate with tests[].adaptive_rate" \
  check "$work/adaptive_key.json"
echo "all bad input refused"
