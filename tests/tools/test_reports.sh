#!/usr/bin/env bash
# Tests tools/report.py on small real runs (tests/run/small_run.json, 150 spheres, a few seconds each): a
# preparation-only run, tests under arbitrary names, a constant-b (failure-surface) deck, a 3-seed ensemble; and
# the force-chain slab on a hand-made contact list.
# Usage: bash tests/tools/test_reports.sh [CELLDEM]      (exits non-zero on the first failure)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
CELLDEM="${1:-$ROOT/build/celldem}"
[[ -x $CELLDEM ]] || fail "no celldem binary at $CELLDEM"

# A variant of the small deck: its tests replaced by those given as JSON (the preparation kept).
deck() {  # out.json tests-json
  "$PY" - "$ROOT/tests/run/small_run.json" "$1" "$2" <<'EOF'
import json, sys
deck = json.load(open(sys.argv[1]))
deck["tests"] = json.loads(sys.argv[3])
json.dump(deck, open(sys.argv[2], "w"))
EOF
}
run() { "$CELLDEM" run "$@" --quiet --threads 1 2>/dev/null || fail "celldem run $*"; }
is_png() { [[ -s $1 && "$(head -c 8 "$1" | od -An -tx1 | tr -d ' \n')" == "89504e470d0a1a0a" ]] || fail "$1: no PNG"; }

echo "1. a preparation-only run: preparation figures and values, no paper table, no test table"
deck "$TMP/prep.json" '[]'
run "$TMP/prep.json" --out "$TMP/prep"
"$PY" "$ROOT/tools/report.py" "$TMP/prep" >/dev/null || fail "report.py on a preparation-only run"
r="$TMP/prep/report.md"
is_png "$TMP/prep/figures/prepare.png"
grep -qF "](figures/prepare.png)" "$r" || fail "preparation figure not in the report"
grep -q "^| void ratio e (–) | 0\.[0-9]* |" "$r" || fail "no prepared void ratio"
for heading in "Comparison with the paper" "Per-test values" "Tests compared"; do
  if grep -q "^##.*$heading" "$r"; then fail "preparation-only run: section '$heading'"; fi
done
if grep -q "n/a" "$r"; then fail "preparation-only run: n/a in the report"; fi

echo "1b. a graded preparation: the report's grading table is summary.json's, row by row"
deck "$TMP/graded.json" '[]'
"$PY" - "$TMP/graded.json" <<'EOF'
import json, sys
deck = json.load(open(sys.argv[1]))
deck["sample"]["diameters"] = {"grading": {"by": "mass", "sizes": [0.003, 0.0036, 0.0045], "passing": [0, 30, 100]}}
json.dump(deck, open(sys.argv[1], "w"))
EOF
run "$TMP/graded.json" --out "$TMP/graded"
"$PY" "$ROOT/tools/report.py" "$TMP/graded" >/dev/null || fail "report.py on a graded run"
"$PY" - "$TMP/graded" <<'EOF' || fail "grading table"
import json, sys
g = json.load(open(sys.argv[1] + "/summary.json"))["grading"]
text = open(sys.argv[1] + "/report.md").read()
assert "## Grading" in text, "no Grading section"
for size, asked, realised in zip(g["sizes_m"], g["asked_percent"], g["realised_percent"]):
    row = f"| {size * 1e3:.4g} | {asked:.2f} | {realised:.2f} |"
    assert row in text, f"no row {row}"
assert f"largest deviation {g['largest_deviation_percent']:.2f} percentage points" in text, "no largest deviation"
EOF
if grep -q "^## Grading" "$TMP/prep/report.md"; then fail "a listed sample's report has a Grading section"; fi

echo "2. tests under arbitrary names: a figure per test, force chains, no paper table"
tests='[{"name":"Squash-A","friction":0.5,"axes":{"x1":{"strain_increment":1e-6},"x2":{"stress":1e5},"x3":{"stress":1e5}},
         "end":{"axis":"x1","strain":0.006},"output_interval":250},
        {"name":"flat_2","friction":0.5,"axes":{"x1":{"strain_increment":1e-6},"x2":{"strain_increment":0},"x3":{"stress":1e5}},
         "end":{"axis":"x1","strain":0.006},"output_interval":250}]'
deck "$TMP/named.json" "$tests"
run "$TMP/named.json" --out "$TMP/named"
"$PY" "$ROOT/tools/report.py" "$TMP/named" >/dev/null || fail "report.py on arbitrarily named tests"
r="$TMP/named/report.md"
for t in Squash-A flat_2; do
  is_png "$TMP/named/figures/test_$t.png"
  grep -qF "](figures/test_$t.png)" "$r" || fail "test $t's figure not in the report"
done
is_png "$TMP/named/figures/force_chains.png"
grep -qF "](figures/force_chains.png)" "$r" || fail "force chains not in the report"
grep -q "^## Force chains" "$r" || fail "no force-chain section"
if grep -q "Comparison with the paper" "$r"; then fail "a paper table for a deck that is not the paper's"; fi
"$PY" - "$r" <<'EOF' || fail "report content of the named run"
import re, sys
from checking import done, error
text = open(sys.argv[1], encoding="utf-8").read()
# The per-test table leads and carries no row that is n/a for every test.
table = [l for l in text.split("## Per-test values", 1)[1].split("\n## ", 1)[0].splitlines() if l.startswith("| ")]
if not table or "Squash-A" not in table[0] or "flat_2" not in table[0]:
    error(f"per-test table header: {table[:1]}")
for row in table[1:]:
    cells = [c.strip() for c in row.strip("|").split("|")][1:]
    if all(c == "n/a" for c in cells):
        error(f"row of n/a: {row}")
n_a = text.count("n/a")
if n_a > 3:
    error(f"{n_a} n/a in the report")
done()
EOF

echo "3. a constant-b deck: the failure surface's table and pi-plane figure in the report"
tests='[{"name":"b0","friction":0.5,"axes":{"x1":{"strain_increment":2e-6},"x2":{"b":0.0},"x3":{"mean_stress":1e5}},"end":{"axis":"x1","strain":0.04},"output_interval":250},
        {"name":"b50","friction":0.5,"axes":{"x1":{"strain_increment":2e-6},"x2":{"b":0.5},"x3":{"mean_stress":1e5}},"end":{"axis":"x1","strain":0.04},"output_interval":250},
        {"name":"b100","friction":0.5,"axes":{"x1":{"strain_increment":2e-6},"x2":{"b":1.0},"x3":{"mean_stress":1e5}},"end":{"axis":"x1","strain":0.04},"output_interval":250}]'
deck "$TMP/fs.json" "$tests"
run "$TMP/fs.json" --out "$TMP/fs"
"$PY" "$ROOT/tools/report.py" "$TMP/fs" >/dev/null || fail "report.py on a constant-b run"
r="$TMP/fs/report.md"
grep -q "^## Failure surface" "$r" || fail "no failure-surface section"
grep -q "^| Matsuoka-Nakai | " "$r" || fail "no criterion table"
for t in b0 b50 b100; do grep -q "^| $t | " "$r" || fail "failure surface: no row of $t"; done
for f in failure_surface_pi_plane failure_surface_phi_b; do
  is_png "$TMP/fs/figures/$f.png"
  grep -qF "](figures/$f.png)" "$r" || fail "$f not in the report"
done
if grep -q "^## Failure surface" "$TMP/named/report.md"; then fail "failure surface for a deck without b tests"; fi

echo "4. a 3-seed ensemble: band figures, statistics from ensemble.json, statistical verdicts"
# small_run.json's tests run to 4 % here, past their peaks (a peak at a test's end is left out of the statistics).
sed 's/"strain":0.006/"strain":0.04/g' "$ROOT/tests/run/small_run.json" > "$TMP/small_long.json"
run "$TMP/small_long.json" --out "$TMP/ens" --seeds 1-3
"$PY" "$ROOT/tools/report.py" "$TMP/ens" --paper >/dev/null || fail "report.py on an ensemble"
r="$TMP/ens/report.md"
for f in test_ttc test_psc fig02_stress_ratio overview prepare force_chains; do
  is_png "$TMP/ens/figures/$f.png"
  grep -qF "](figures/$f.png)" "$r" || fail "ensemble: $f not in the report"
done
"$PY" - "$TMP/ens" <<'EOF' || fail "ensemble report"
import json, os, re, sys
from celldem import results
from celldem.reports import figures, plotting
from checking import done, error
ens_dir = sys.argv[1]
ens = results.load_run_or_report(ens_dir, "test")
stats = json.load(open(os.path.join(ens_dir, "ensemble.json")))
text = open(os.path.join(ens_dir, "report.md"), encoding="utf-8").read()
if len(ens.runs) != 3:
    error(f"{len(ens.runs)} seed runs loaded")
if "band ± 1 standard deviation" not in text:
    error("the report does not say what the band is")
# Per-test and paired numbers are ensemble.json's.
peak = stats["tests"]["psc"]["peak_ratio13"]
if f"| peak σ1/σ3 (–) | {peak['mean']:.3f} ± {peak['std']:.3f} [{peak['ci95'][0]:.3f}, {peak['ci95'][1]:.3f}]" not in text:
    error("per-test peak is not ensemble.json's")
diff = stats["paired"]["ttc-psc"]["peak_ratio13"]
row = next((l for l in text.splitlines() if l.startswith("| peak σ1/σ3 (–) | ttc − psc |")), None)
if row is None or f"{diff['mean']:.3f} ± {diff['std']:.3f}" not in row:
    error(f"paired difference is not ensemble.json's: {row}")
lo, hi = diff["ci95"]
# A difference called after Holm's adjustment is called without it too: its 95 % interval excludes 0.
allowed = ["not distinguishable at 3 seeds"] + (["ttc lower than psc"] if hi < 0 else []) + \
    (["ttc higher than psc"] if lo > 0 else [])
if row is not None and not any(row.rstrip(" |").endswith(w) for w in allowed):
    error(f"paired verdict: want one of {allowed} in {row}")
if row is not None and "Holm" not in row:
    error(f"the paired verdict does not give its Holm-adjusted p: {row}")
if "family-wise error rate of 5 %" not in text:
    error("the report does not state its family-wise error rate")
# The paper's findings judged statistically, naming the test used.
paper = text.split("## Comparison with the paper", 1)[-1].split("\n## ", 1)[0]
rows = [l for l in paper.splitlines() if l.startswith("| ") and not l.startswith("| Finding")]
if len(rows) < 10:
    error(f"{len(rows)} findings judged")
if not any("paired t" in l for l in rows) or not any("one-sample t" in l for l in rows):
    error("the findings do not name their tests")
verdict = r"\| (yes|no[^|]*|not distinguishable at 3 seeds[^|]*|consistent[^|]*|equivalent|different|undecided at 3 seeds) \|$"
if not all(re.search(verdict, l) for l in rows):
    error("a finding without a verdict: " + next(l for l in rows if not re.search(verdict, l)))
if not any("prediction interval" in l for l in rows) or not any("TOST, margin" in l for l in rows):
    error("the paper's values are not judged by prediction intervals, or sameness not by TOST")
prep = stats["prepared"]["void_ratio"]
if not any(l.startswith("| Prepared void ratio e | 0.570 | " + f"{prep['mean']:.3f} ± {prep['std']:.3f}") for l in rows):
    error("prepared void ratio is not ensemble.json's")
# Every curve of an ensemble figure is a mean with a band.
plt = plotting.pyplot()
entry = next(p for p in figures.plan(ens, True) if p.stem == "fig02_stress_ratio")
fig = entry.make(plt)
ax = fig.axes[0]
if len(ax.collections) != 2 or len(ax.lines) != 2:
    error(f"stress ratio of an ensemble: {len(ax.collections)} bands, {len(ax.lines)} lines (want 2 and 2)")
done()
EOF

echo "5. the force-chain slab: strong contacts only, the particle inside the slab, periodic images"
"$PY" - <<'EOF' || fail "force-chain slab"
import numpy as np
from celldem.reports import force_chains
from checking import check, done, error
h = np.diag([0.01, 0.01, 0.01])
xi = np.array([[0.005, 0.005, 0.005],    # in the slab (x2 = 5 mm): kept, from i
               [0.005, 0.0001, 0.005],   # i below the slab; j = i + branch wraps into it: kept, from j
               [0.002, 0.005, 0.002],    # in the slab but weak: left out
               [0.002, 0.009, 0.002]])   # neither end in the slab: left out
branch = np.array([[0.003, 0.0, 0.0], [0.0, -0.0052, 0.001], [0.003, 0.0, 0.0], [0.003, 0.0, 0.0]])
force = np.array([10.0, 8.0, 1.0, 9.0])  # mean 7
start, end, f = force_chains.slab_segments(xi, branch, force, h, thickness=0.0015)
check("contacts in the slab", len(f), 2)
check("forces", list(f), [10.0, 8.0])
if not np.allclose(start[0], xi[0]) or not np.allclose(end[0], xi[0] + branch[0]):
    error("contact with i in the slab not drawn from i")
if not np.allclose(start[1], [0.005, 0.0049, 0.006]) or not np.allclose(end[1] - start[1], -branch[1]):
    error(f"contact across the boundary not drawn from j's wrapped centre: {start[1]} -> {end[1]}")
done()
EOF

echo "PASS: report tests on real runs"
