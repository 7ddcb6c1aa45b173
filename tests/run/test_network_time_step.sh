#!/usr/bin/env bash
# The time step against the contact network's own stability limit 2/omega_max (docs/physics.md, "The network's
# margin"): a step above 1.1 of it is refused with exit 2, the message naming the stage, the ratio, the margin and
# the key, by `check` and `run` before a run from an initial_state, and by `run` when a test starts from the state
# its preparation made; a step between 0.9 and 1.1 of it runs with a warning naming the margin. The deck has stiff
# rolling springs (held in the tests by their rolling friction), which the network couples far more than one pair
# does, so the network's limit lies well below the pair formula's bounds that the deck reader applies: the steps
# tried here are taken from the network's limit as `plan --json` measures it on the prepared state.
# Usage: test_network_time_step.sh CELLDEM
set -uo pipefail
celldem="$1"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
src="$(dirname "$0")/small_run.json"

# deck.py OUT [key=value ...]: small_run.json with rolling springs, its ttc test cut short, edited by the pairs
# (prepare=none drops the preparation; initial_state=PATH starts from PATH; time_step=X; prepare_time_step=X).
cat > "$work/deck.py" <<'EOF'
import json, sys
d = json.load(open(sys.argv[1]))
d["contact"].update({"rolling": "sds", "rolling_stiffness": 2e7, "rolling_friction": 0.1})
d["tests"] = d["tests"][:1]
d["tests"][0]["end"] = {"steps": 300}
d["tests"][0]["output_interval"] = 100
for pair in sys.argv[3:]:
    key, value = pair.split("=", 1)
    if key == "prepare" and value == "none":
        d.pop("prepare")
    elif key == "initial_state":
        d["initial_state"] = value
    elif key == "time_step":
        d["time_step"] = float(value)
    elif key == "prepare_time_step":
        d["prepare"]["time_step"] = float(value)
json.dump(d, open(sys.argv[2], "w"), indent=1)
EOF
deck() { /usr/bin/python3 "$work/deck.py" "$src" "$@" || fail "writing $1"; }

# A prepared packing (the preparation is frictionless: its network is the normal springs alone).
deck "$work/prep.json"
"$celldem" run "$work/prep.json" --out "$work/prep" --quiet --threads 1 || fail "the preparation at the deck's step"
state="$work/prep/prepared.state"

# The test's network limit on that state (sliding and rolling friction: every spring), and the pair bound t_c.
deck "$work/probe.json" prepare=none initial_state="$state"
"$celldem" plan "$work/probe.json" --json > "$work/plan.json" || fail "plan --json"
read -r limit t_c < <(/usr/bin/python3 -c '
import json, sys
p = json.load(open(sys.argv[1]))
s = p["network_time_step"]["stages"][0]
assert s["stage"] == "ttc" and s["tangential_springs"], s
print(s["limit"], p["critical_time_step"])' "$work/plan.json") || fail "no network limit in plan --json"
refused_dt=$(/usr/bin/python3 -c "print(1.15 * $limit)")
warned_dt=$(/usr/bin/python3 -c "print(1.0 * $limit)")
/usr/bin/python3 -c "import sys; sys.exit(0 if 1.15 * $limit < 0.9 * $t_c else 1)" ||
  fail "the network's limit $limit s is not below the pair bounds (t_c $t_c s): no step to refuse"
echo "network limit $limit s, t_c $t_c s: refused at $refused_dt s, warned at $warned_dt s"

# expect_refused WHAT NEEDLE... -- ARGS: exit 2 and every NEEDLE in the message.
expect_refused() {
  local what="$1"
  shift
  local needles=()
  while [[ $1 != -- ]]; do needles+=("$1"); shift; done
  shift
  "$celldem" "$@" > "$work/out" 2> "$work/err"
  local rc=$?
  [[ $rc -eq 2 ]] || { cat "$work/out" "$work/err"; fail "$what: exit code $rc, expected 2"; }
  for n in "${needles[@]}"; do
    grep -qF -- "$n" "$work/err" || { cat "$work/err"; fail "$what: the message does not name '$n'"; }
  done
  echo "ok: $what -> $(grep -m1 -o 'is [0-9.]* of the contact network[^=]*= [^ ]* s' "$work/err")"
}

# From initial_state: check and run refuse before anything runs.
deck "$work/fast.json" prepare=none initial_state="$state" time_step="$refused_dt"
for command in check run; do
  args=("$command" "$work/fast.json")
  [[ $command == run ]] && args+=(--out "$work/fast" --quiet --threads 1)
  expect_refused "$command from initial_state" "test 'ttc' from initial_state" "the refusal margin 1.1" \
    "set time_step to at most" -- "${args[@]}"
done
[[ ! -e $work/fast/ttc/series.csv ]] || fail "the refused run wrote a series"

# From the run's own preparation (at its own step, the state above): the test is refused as it starts.
deck "$work/staged.json" time_step="$refused_dt" prepare_time_step=1e-6
"$celldem" check "$work/staged.json" > /dev/null 2>&1 || fail "check refused a deck whose tests' network is not known yet"
expect_refused "run, the test from the prepared state" "stage 'ttc' as it starts" "the refusal margin 1.1" \
  "set time_step to at most" -- run "$work/staged.json" --out "$work/staged" --quiet --threads 1
[[ -f $work/staged/prepared.state ]] || fail "the preparation did not run before the test was refused"
[[ ! -e $work/staged/ttc/series.csv ]] || fail "the refused test wrote a series"

# Between the margins: a warning naming the margin, and the run goes on.
deck "$work/close.json" prepare=none initial_state="$state" time_step="$warned_dt"
"$celldem" check "$work/close.json" > "$work/out" 2>&1 || { cat "$work/out"; fail "check refused a step at the limit"; }
grep -qF "above the margin 0.9" "$work/out" || { cat "$work/out"; fail "check did not warn of the margin"; }
"$celldem" run "$work/close.json" --out "$work/close" --quiet --threads 1 > "$work/out" 2>&1 ||
  { cat "$work/out"; fail "run refused a step at the limit"; }
/usr/bin/python3 - "$work/close/summary.json" <<'EOF' || fail "summary.json lacks the warning or the record"
import json, sys
s = json.load(open(sys.argv[1]))
assert any("above the margin 0.9" in w for w in s["warnings"]), s["warnings"]
n = s["tests"]["ttc"]["network_time_step"]
assert n["at_start"]["verdict"] == "warn" and n["checks"] >= 1, n
EOF
echo "ok: a step at the network's limit runs with the warning"
echo "PASS"
