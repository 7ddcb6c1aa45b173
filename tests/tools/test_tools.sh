#!/usr/bin/env bash
# Tests tools/figures.py and tools/report.py on synthetic run directories (tests/tools/make_fake_run.py):
# the figures are written, the report's comparison table holds the numbers built into the fake data, the report
# quotes summary.json's quantities rather than recomputing them (the fake runs' summaries come from `celldem
# summarize`), and `celldem summarize` takes s11/s33 for a series without ratio13 (LAMMPS/LIGGGHTS series).
# Usage: bash tests/tools/test_tools.sh      (exits non-zero on the first failure)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"

# Checks report.md against expected.json. Mode "alike": the run agrees with the paper; "diverging": the fake
# PSC differs from TTC, so each comparison between the tests must say "no".
check_report() {
  "$PY" - "$1" "$2" <<'EOF'
import json, os, re, sys

run_dir, mode = sys.argv[1], sys.argv[2]
expected = json.load(open(os.path.join(run_dir, "expected.json")))
text = open(os.path.join(run_dir, "report.md"), encoding="utf-8").read()
from checking import check, done, error

# The first Markdown table of the report, rows keyed by their first cell.
lines = text.splitlines()
start = next(i for i, l in enumerate(lines) if l.startswith("|"))
rows = {}
for line in lines[start + 2:]:
    if not line.startswith("|"):
        break
    cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
    rows[cells[0]] = cells

def expect(row, column, wanted, how="equals"):
    got = rows.get(row, [None] * 5)[column]
    ok = got == wanted if how == "equals" else (got is not None and got.startswith(wanted))
    if not ok:
        error(f"row {row!r} column {column}: expected {how} {wanted!r}, got {got!r}")

RUN, MATCH = 2, 3
expect("Prepared void ratio e", RUN, f"{expected['prepared_void_ratio']:.3f}")
expect("Prepared coordination number Z", RUN, f"{expected['prepared_Z']:.2f}")
expect("PSC b at peak σ1/σ3", RUN, f"{expected['psc_b_at_peak']:.3f}")
expect("PSC b at peak σ1/σ3", MATCH, "yes")
expect("PSC b at ε1 = 10 %", RUN, f"{expected['psc_b_at_10']:.3f}")
peaks = expected["peaks"]
yn = lambda flag: "yes" if flag else "no"
expect("PSC peak σ1/σ3 exceeds TTC's", RUN,
       f"{yn(expected['psc_peak_exceeds_ttc'])} (psc {peaks['psc']:.3f}, ttc {peaks['ttc']:.3f})")
expect("PSC peak σ1/σ3 exceeds TTC's", MATCH, yn(expected["psc_peak_exceeds_ttc"]))
fab = expected["fabric_peak"]
expect("H11/H33 grows more in PSC", RUN, f"yes (max psc {fab['psc']:.3f}, ttc {fab['ttc']:.3f})")
for row, key in (("Z evolves alike in TTC and PSC", "z_alike"),
                 ("Sliding fraction evolves alike in TTC and PSC", "sliding_alike"),
                 ("σ1/σ3 vs Hs11/Hs33 (ε1 ≤ 1 %) is one curve for both tests", "macro_micro_unique")):
    expect(row, RUN, yn(expected[key]) + " (", how="starts with")
    expect(row, MATCH, yn(expected[key]))
expect("TTC b stays 0", MATCH, "yes")
expect("PSC ε2 stays 0", MATCH, "yes")

# Per-test values: the peaks, computed from the series.
for name, peak in peaks.items():
    if not re.search(r"\| peak σ1/σ3 \(–\) \|.*\b%s\b" % re.escape(f"{peak:.3f}"), text):
        error(f"per-test table lacks peak σ1/σ3 {peak:.3f} of {name}")

# Every embedded figure exists, and the paper's Figures 2-12 are all there.
links = re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)
for link in links:
    if not link.startswith("figures/") or not os.path.isfile(os.path.join(run_dir, link)):
        error(f"figure link {link} does not resolve inside the run directory")
for n in range(2, 13):
    if not any(os.path.basename(l).startswith(f"fig{n:02d}_") for l in links):
        error(f"no Figure {n} embedded")

done()
EOF
}

check_pngs() {
  local dir="$1" count=0
  for f in "$dir"/fig02_*.png "$dir"/fig03_*.png "$dir"/fig04_*.png "$dir"/fig05_*.png "$dir"/fig06_*.png \
           "$dir"/fig07_*.png "$dir"/fig08_*.png "$dir"/fig09_*.png "$dir"/fig10_*.png "$dir"/fig11_*.png \
           "$dir"/fig12_*.png "$dir"/overview.png; do
    [[ -s "$f" ]] || fail "missing or empty figure $f"
    [[ "$(head -c 8 "$f" | od -An -tx1 | tr -d ' \n')" == "89504e470d0a1a0a" ]] || fail "$f is not a PNG"
    count=$((count + 1))
  done
  [[ $count -eq 12 ]] || fail "expected 12 figures in $dir, found $count"
}

echo "1. run alike to the paper: figures.py, then report.py"
"$PY" "$ROOT/tests/tools/make_fake_run.py" "$TMP/alike"
"$PY" "$ROOT/tools/figures.py" "$TMP/alike" >/dev/null || fail "figures.py failed"
check_pngs "$TMP/alike/figures"
"$PY" "$ROOT/tools/report.py" "$TMP/alike" >/dev/null || fail "report.py failed"
check_report "$TMP/alike" alike || fail "report of the alike run"

echo "1b. the package on the alike run: series columns by header, units, a series without ratio13"
"$PY" - "$TMP/alike" <<'EOF' || fail "package functions on the alike run"
import sys
import os, tempfile
from celldem import binary, results
from celldem.reports import plotting
from checking import check, done, error
run = results.load_run(sys.argv[1])
for test in run.test_names:
    # Without a ratio13 column (a translated script's series) `celldem summarize` takes s11/s33.
    lammps_like = {k: v for k, v in run.test(test).items() if k not in ("ratio13", "b")}
    fd, path = tempfile.mkstemp(suffix=".csv")
    with os.fdopen(fd, "w") as f:
        f.write(",".join(lammps_like) + "\n")
        for row in zip(*lammps_like.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    got = binary.summarize(path)["peak_ratio13"]
    os.remove(path)
    if abs(got - run.quantity(test, "peak_ratio13")) > 1e-9 * got:
        error(f"{test}: the peak of s11/s33 ({got}) differs from ratio13's ({run.quantity(test, 'peak_ratio13')})")
if run.quantity("psc", "end_window.ev") != run.test_summary("psc")["end_window"]["ev"]:
    error("Run.quantity does not follow a key path")
if run.unit("s11") != "Pa" or run.unit("e1") != "-":
    error(f"units from series.columns.json: s11 {run.unit('s11')!r}, e1 {run.unit('e1')!r}")
if plotting.unit_text(run.unit("s11"), 1e-3) != "(kPa)" or plotting.unit_text(run.unit("e1"), 100) != "(%)":
    error("axis units")
done()
EOF

echo "1c. the report quotes summary.json's peak, ε1 and b at the peak, not values recomputed from the series"
cp -r "$TMP/alike" "$TMP/edited"
"$PY" - "$TMP/edited/summary.json" <<'EOF'
import json, sys
path = sys.argv[1]
s = json.load(open(path))
s["tests"]["psc"].update(peak_ratio13=4.321, e1_at_peak=0.0123, b_at_peak=0.377)
s["tests"]["ttc"].update(peak_ratio13=4.4, end_window={"strain": 0.005, "ev": -0.0555, "Z": 4.56})
json.dump(s, open(path, "w"))
EOF
"$PY" "$ROOT/tools/report.py" "$TMP/edited" >/dev/null || fail "report.py failed on the edited run"
r="$TMP/edited/report.md"
grep -qF "| PSC b at peak σ1/σ3 | 0.396 | 0.377 | yes |" "$r" || fail "report does not quote summary.json b_at_peak"
grep -qF "| PSC peak σ1/σ3 exceeds TTC's | yes | no (psc 4.321, ttc 4.400) | no |" "$r" \
  || fail "report does not compare summary.json's peaks"
grep -qF "| peak σ1/σ3 (–) | 4.400 | 4.321 |" "$r" || fail "per-test table does not quote summary.json's peaks"
grep -qF "| ε1 at peak σ1/σ3 (%) | 2.500 | 1.230 |" "$r" || fail "per-test table does not quote summary.json e1_at_peak"
grep -qF "| εv, Z over the end window (%, –) | -5.550, 4.56 |" "$r" || fail "per-test table lacks the end window"

echo "2. run whose tests diverge: report.py alone draws the missing figures"
"$PY" "$ROOT/tests/tools/make_fake_run.py" "$TMP/diverging" --variant diverging
"$PY" "$ROOT/tools/report.py" "$TMP/diverging" >/dev/null || fail "report.py failed"
check_pngs "$TMP/diverging/figures"
check_report "$TMP/diverging" diverging || fail "report of the diverging run"

echo "2b. figures older than the run's data are redrawn; up-to-date ones are kept"
fig="$TMP/diverging/figures/fig02_stress_ratio.png"
touch -d "2000-01-01" "$TMP/diverging/figures/"*.png
touch -d "2000-01-02" $(find "$TMP/diverging" -type f ! -path "*/figures/*")
"$PY" "$ROOT/tools/report.py" "$TMP/diverging" >/dev/null || fail "report.py failed"
[[ $(stat -c %Y "$fig") -gt $(date -d "2001-01-01" +%s) ]] || fail "a figure older than the run's series was not redrawn"
touch -d "2000-01-01" $(find "$TMP/diverging" -type f ! -path "*/figures/*")
before=$(stat -c %Y "$fig")
"$PY" "$ROOT/tools/report.py" "$TMP/diverging" >/dev/null || fail "report.py failed"
[[ $(stat -c %Y "$fig") -eq $before ]] || fail "an up-to-date figure was redrawn"

echo "3. one test, optional columns and the prepared stage missing: no empty figure, no row of n/a, not a crash"
"$PY" "$ROOT/tests/tools/make_fake_run.py" "$TMP/partial" --only ttc --no-prepared --no-columns-json \
  --reverse-columns --drop-columns Hs11_Hs33,Hs11,Hw11_Hw33,DI,Zm,sin_phi,kinetic_energy,unbalanced_force
"$PY" "$ROOT/tools/report.py" "$TMP/partial" >/dev/null || fail "report.py failed on a partial run"
r="$TMP/partial/report.md"
for f in fig02_stress_ratio fig04_volumetric_strain fig06_b_value fig07_coordination test_ttc; do
  [[ -s "$TMP/partial/figures/$f.png" ]] || fail "partial run: $f.png missing"
done
for f in fig05_dilatancy_index fig10_fabric_strong fig12_macro_micro extra_balance; do  # Hw11_Hw33 comes back from Hw11/Hw33
  [[ ! -e "$TMP/partial/figures/$f.png" ]] || fail "partial run: $f.png drawn without its columns"
  if grep -q "$f.png" "$r"; then fail "partial run: report links $f.png"; fi
done
grep -q "^Not judged .*PSC b at peak σ1/σ3" "$r" || fail "partial run: PSC findings not listed as not judged"
if grep -q "| PSC b at peak σ1/σ3 |" "$r"; then fail "partial run: a row of n/a for PSC b"; fi
if grep -q "| max Hs11/Hs33 (–) |" "$r"; then fail "partial run: a per-test row of n/a"; fi
grep -q "first row of ttc/series.csv" "$r" || fail "partial run: no fallback for prepared"

echo "4. figures.py --out writes elsewhere"
"$PY" "$ROOT/tools/figures.py" "$TMP/alike" --out "$TMP/elsewhere" >/dev/null || fail "figures.py --out failed"
check_pngs "$TMP/elsewhere"

echo "4b. the paper's scene with tests under other names is not the paper's deck: per-test figures, no paper table"
"$PY" "$ROOT/tests/tools/make_fake_run.py" "$TMP/renamed"
mv "$TMP/renamed/ttc" "$TMP/renamed/Squash_1"
mv "$TMP/renamed/psc" "$TMP/renamed/plane-2"
"$PY" - "$TMP/renamed/summary.json" <<'EOF'
import json, sys
s = json.load(open(sys.argv[1]))
s["tests"] = {"Squash_1": s["tests"]["ttc"], "plane-2": s["tests"]["psc"]}
json.dump(s, open(sys.argv[1], "w"))
EOF
"$PY" "$ROOT/tools/report.py" "$TMP/renamed" >/dev/null || fail "report.py failed on renamed tests"
r="$TMP/renamed/report.md"
if grep -q "Comparison with the paper" "$r"; then fail "renamed tests: paper table"; fi
for t in Squash_1 plane-2; do
  [[ -s "$TMP/renamed/figures/test_$t.png" ]] || fail "renamed tests: no figure of test $t"
  grep -qF "](figures/test_$t.png)" "$r" || fail "renamed tests: test $t's figure not in the report"
done
grep -q "^## Per-test values" "$r" || fail "renamed tests: no per-test values"
"$PY" "$ROOT/tools/report.py" "$TMP/renamed" --paper >/dev/null || fail "report.py --paper failed"
grep -q "^## Comparison with the paper" "$TMP/renamed/report.md" || fail "--paper: no paper table"

echo "5. a missing run directory or summary.json is an error with a message"
for tool in figures.py report.py; do
  if "$PY" "$ROOT/tools/$tool" "$TMP/no-such-run" 2>"$TMP/err"; then fail "$tool accepted a missing run dir"; fi
  grep -q "run directory not found" "$TMP/err" || fail "$tool: unclear message for a missing run dir"
  mkdir -p "$TMP/no-summary/ttc"
  if "$PY" "$ROOT/tools/$tool" "$TMP/no-summary" 2>"$TMP/err"; then fail "$tool accepted a run without summary"; fi
  grep -q "summary.json not found" "$TMP/err" || fail "$tool: unclear message for a missing summary.json"
done
[[ ! -e "$TMP/no-summary/report.md" ]] || fail "report.md written for a run without summary.json"

echo "PASS: tools tests"
