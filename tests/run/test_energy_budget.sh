#!/usr/bin/env bash
# The energy budget on a sheared periodic packing (small_run.json: 150 spheres, TTC and PSC with friction and
# body damping): kept, it changes no bit of the other columns; each test's budget closes within the bound measured
# for it (docs/energy.md: end closure below 1e-5, worst row below 2e-3 of the boundary work); summary.json reports totals per test and
# per leg, and damping's share. Usage: test_energy_budget.sh CELLDEM
set -euo pipefail
celldem="$1"
here="$(dirname "$0")"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
grep -q '^{"format":1,$' "$here/small_run.json" || fail "small_run.json changed: adapt this test"
sed 's/^{"format":1,/{"format":1,"energy_budget":true,/' "$here/small_run.json" > "$work/energy.json"
"$celldem" run "$here/small_run.json" --out "$work/plain" --threads 1 --quiet
"$celldem" run "$work/energy.json" --out "$work/energy" --threads 2 > "$work/console.txt"
/usr/bin/python3 - "$work" <<'PY'
import csv, json, math, sys
work = sys.argv[1]
def rows(path):
    with open(path) as f:
        return list(csv.reader(f))
for test in ("ttc", "psc"):
    plain, energy = rows(f"{work}/plain/{test}/series.csv"), rows(f"{work}/energy/{test}/series.csv")
    assert energy[0] == plain[0], "one header with or without the budget"
    width = next(k for k, c in enumerate(plain[0]) if c.startswith("energy_"))
    assert all(c.startswith("energy_") for c in energy[0][width:]), "the energy columns come after the others"
    assert [r[:width] for r in energy] == [r[:width] for r in plain], f"{test}: keeping the budget changed other columns"
    assert all(v == "nan" for r in plain[1:] for v in r[width:]), "no budget: no energy columns"
    header = energy[0]
    col = {n: i for i, n in enumerate(header)}
    last = energy[-1]
    work_done = float(last[col["energy_boundary_work"]])
    assert work_done > 0, f"{test}: the cell did work on the sample ({work_done})"
    closure = float(last[col["energy_closure_relative"]])
    # The cap credited at the mean of the step's two forces closes to ~6e-7 here; the end force alone gave 1.2e-4.
    assert abs(closure) < 1e-5, f"{test}: closure {closure} of the boundary work"
    summary = json.load(open(f"{work}/energy/summary.json"))["tests"][test]["energy"]
    assert summary["closure_within_bound"] is True and summary["worst_closure_relative"] < 2e-3, summary
    assert abs(summary["boundary_work"] - (work_done - float(energy[1][col["energy_boundary_work"]]))) <= 1e-9 * work_done
    parts = summary["stored_change"] + summary["kinetic_change"] + summary["dissipated"] + summary["closure"]
    assert math.isclose(parts, summary["boundary_work"], rel_tol=1e-9), summary
    assert 0 <= summary["damping_share"] <= 1 and len(summary["legs"]) >= 1, summary
    print(f"{test}: work {work_done:.4g} J, closure {closure:.3g}, worst {summary['worst_closure_relative']:.3g}, "
          f"damping share {summary['damping_share']:.3g}")
PY
grep -q "energy: boundary work" "$work/console.txt" || fail "the console has no energy line"
echo PASS
