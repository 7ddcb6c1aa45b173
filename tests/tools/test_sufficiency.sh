#!/usr/bin/env bash
# Tests tools/sufficiency.py (tools/celldem/study/sufficiency.py): the switches' decks (linear equivalents at the mean
# contact force, unused keys removed, drag kept, every variant accepted by celldem), the change measure and its
# verdicts on known numbers; then a real run of the tool on a small scene of inputs/paper.json (100 spheres, tests to
# ε1 = 4 %, past most peaks; a peak at a test's end is left out and listed, 2 seeds, about 10 s): sufficiency.json and sufficiency.md, the switches the paper deck does not
# use reported as skipped; and that `study.py analyse` includes the table in the study's report.
# Usage: bash tests/tools/test_sufficiency.sh [CELLDEM]      (exits non-zero on the first failure)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
CELLDEM="${1:-$ROOT/build/celldem}"
[[ -x $CELLDEM ]] || fail "no celldem binary at $CELLDEM"
export CELLDEM

echo "1. the switches and the change measure on known inputs"
"$PY" - "$ROOT" "$TMP" <<'EOF' || fail "switches and change measure"
import json, math, os, subprocess, sys
from celldem import binary, decks
from celldem.study import sufficiency as su
from checking import check, done, error

repo, tmp = sys.argv[1], sys.argv[2]
celldem = os.environ["CELLDEM"]
rolling = su.reduce_deck(decks.load(os.path.join(repo, "inputs", "rolling.json")), 300, 0.04)
check("reduced count", rolling["sample"]["count"], 300)
check("reduced end strains", [t["end"]["strain"] for t in rolling["tests"]], [0.04, 0.04])

# The mean contact at 100 kPa from `celldem plan`, against a hand calculation: F = pi d^2 p / 3.6, Hertz overlap
# of two mean spheres (R* = d/4).
d, p, e, nu = 3.75e-3, 1.0e5, 7.0e10, 0.25
force = math.pi * d * d * p / 3.6
e_star, g_star = e / (2 * (1 - nu * nu)), e / (4 * (2 - nu) * (1 + nu))
overlap = (3 * force / (4 * e_star * math.sqrt(d / 4))) ** (2 / 3)
cm = su.mean_contact(binary.plan_deck(rolling, None, celldem))
check("confining stress", cm["pressure"], p)
check("mean diameter", cm["mean_diameter"], d, 1e-12)
check("mean force", cm["force"], force, 1e-12)
check("hertz overlap", cm["overlap"], overlap, 1e-12)
check("secant kn", cm["kn_secant"], force / overlap, 1e-12)
check("mindlin kt", cm["kt_mindlin"], 8 * g_star * math.sqrt(d / 4 * overlap), 1e-12)

configs = {key: (vdeck, info) for key, _, vdeck, info in su.variants(rolling, celldem)}
check("rolling deck: every switch applies", sorted(k for k, (v, _) in configs.items() if v is None), [])
n, t, r, w = (configs[k][0]["contact"] for k in ("normal", "tangential", "rolling", "twisting"))
check("normal → linear", n["normal"], "linear")
check("secant kn set", n["kn"], cm["kn_secant"], 1e-12)
check("tangential → linear_history", t["tangential"], "linear_history")
check("mindlin kt set", t["kt"], cm["kt_mindlin"], 1e-12)
check("rolling → none, its keys gone", (r["rolling"], sorted(k for k in r if k.startswith("rolling_"))), ("none", []))
check("rolling → none, the tests' rolling friction gone",
      [k for t in configs["rolling"][0]["tests"] for k in t if k == "rolling_friction"], [])
check("normal → linear keeps E and nu for mindlin", (n["youngs_modulus"], n["poisson_ratio"]), (e, nu))
check("tangential → linear_history keeps E and nu for hertz", (t["youngs_modulus"], t["poisson_ratio"]), (e, nu))
both = json.loads(json.dumps(rolling))
both["contact"].update(normal="linear", tangential="linear_history", kn=1e6, kt=1e6)
both = su.clean(both, binary.schema(celldem))
check("clean: no E, nu or reference overlap without hertz and mindlin",
      sorted(k for k in ("youngs_modulus", "poisson_ratio", "reference_overlap") if k in both["contact"]), [])
check("twisting → none", (w["twisting"], w["rolling"]), ("none", "sds"))
check("rotational damping → 0", configs["rotational_damping"][0]["damping"]["rotational"], 0.0)
check("kinematics → lammps", configs["kinematics"][0]["kinematics"], "lammps")
base_plan = binary.plan_deck(rolling, None, celldem)["particle_types"][0]
for key, (vdeck, info) in configs.items():
    if vdeck is None:
        continue
    path = os.path.join(tmp, f"{key}.json")
    decks.write(path, vdeck)
    r_ = subprocess.run([celldem, "check", path], capture_output=True, text=True)
    if r_.returncode != 0:
        error(f"celldem check refuses the {key} variant: {r_.stderr.strip()}")
    if key in ("normal", "tangential"):  # a contact-law switch keeps the baseline's drag coefficients
        vp = binary.plan_deck(vdeck, None, celldem)["particle_types"][0]
        check(f"{key}: translational drag kept", vp["translational_drag"], base_plan["translational_drag"], 1e-9)
        check(f"{key}: rotational drag kept", vp["rotational_drag"], base_plan["rotational_drag"], 1e-9)
check("normal switch rescales the damping", configs["normal"][1]["damping_factors"]["translational"] > 1.5, True)

paper = decks.load(os.path.join(repo, "inputs", "paper.json"))
skipped = {k: i.get("skipped") for k, _, v, i in su.variants(su.reduce_deck(paper, 40, 0.005), celldem) if v is None}
check("paper deck: skipped switches", sorted(skipped), ["normal", "rolling", "tangential", "twisting"])
check("skip reason", skipped["normal"], "skipped: normal is linear")
check("b only for the non-axisymmetric test", [q for q in su.quantities_of(paper) if q[1] == "b_peak"],
      [("psc", "b_peak")])

# The change: paired differences per seed, paired t, TOST within a noise floor; verdicts by judge_switch.
floor = 1.0
c = su.change([2.0, 2.1, 1.9, 2.05], floor)
check("delta", c["delta"], 2.0125, 1e-12)
check("noise units", c["noise_units"], 2.0125, 1e-12)
check("margin", c["margin"], 1.0)
check("verdict needed", su.judge_switch({"a": c}), "needed")
check("quantity changes", c["verdict"], "changes")
check("verdict not needed", su.judge_switch({"a": su.change([0.01, -0.02, 0.0, 0.01], floor)}), "not needed")
check("undecided", su.judge_switch({"a": su.change([1.5, -1.4, 0.9, -0.2], floor)}), "undecided at 4 seeds")
check("no spread", su.change([1.0, 2.0], 0.0)["margin"], None)
check("no values", su.change([], 1.0), None)
check("paired by seed", su.paired({1: 1.0, 2: 2.0, 3: 5.0}, {2: 2.5, 1: 0.5}), [-0.5, 0.5])

# Robust peak fields when summary.json has them, the plain ones otherwise.
info = {"peak_ratio13": 3.0, "e1_at_peak": 0.01, "b_at_peak": 0.4, "final_e1": 0.03,
        "end_window": {"ev": -0.02, "Z": 4.4}, "peak_robust": {"ratio13": 2.9, "e1": 0.012, "b_mean": 0.38}}
m = su.run_metrics({"tests": {"psc": info}}, 0.03)["psc"]
check("robust peak", (m["peak_ratio"], m["e1_peak"], m["b_peak"], m["ev_end"], m["Z_end"]),
      (2.9, 0.012, 0.38, -0.02, 4.4))
info.pop("peak_robust")
check("plain peak", su.run_metrics({"tests": {"psc": info}}, 0.03)["psc"]["peak_ratio"], 3.0)
done()
EOF

echo "2. the tool on a tiny scene of the paper deck (2 seeds)"
out="$TMP/sufficiency-tiny"
"$PY" "$ROOT/tools/sufficiency.py" "$ROOT/inputs/paper.json" --out "$out" --seeds 2 --count 100 --end-strain 0.04 \
  --celldem "$CELLDEM" >"$TMP/log" 2>&1 || { cat "$TMP/log"; fail "sufficiency.py failed"; }
for f in sufficiency.json sufficiency.md; do [[ -s "$out/$f" ]] || fail "no $f"; done
"$PY" - "$out" <<'EOF' || fail "sufficiency.json and .md"
import json, sys
from checking import check, done, error
root = sys.argv[1]
r = json.load(open(f"{root}/sufficiency.json"))
check("seeds", r["seeds"], [1, 2])
check("scene", (r["scene"]["count"], r["scene"]["end_strain"]), (100, 0.04))
qs = ["ttc.peak_ratio", "ttc.e1_peak", "ttc.ev_end", "ttc.Z_end",
      "psc.peak_ratio", "psc.e1_peak", "psc.ev_end", "psc.Z_end", "psc.b_peak"]
check("quantities", r["quantities"], qs)
rows = {x["key"]: x for x in r["rows"]}
check("rows", [x["key"] for x in r["rows"]],
      ["baseline", "normal", "tangential", "rolling", "twisting", "rotational_damping", "kinematics"])
for k in ("normal", "tangential", "rolling", "twisting"):
    if not rows[k]["verdict"].startswith("skipped"):
        error(f"{k} should be skipped for the paper deck, verdict {rows[k]['verdict']!r}")
for k in ("rotational_damping", "kinematics"):
    row = rows[k]
    check(f"{k} seeds", row.get("seeds"), [1, 2])
    if row["verdict"] not in ("needed", "not needed", "undecided at 2 seeds", "undecided at 1 seeds"):
        error(f"{k}: verdict {row['verdict']!r}")
    check(f"{k} quantities", sorted(row["changes"]), sorted(qs))
    c = row["changes"]["ttc.peak_ratio"]
    # The seeds whose TTC reached its peak in both runs (a peak at the test's end is left out).
    peaked = [s for s in (1, 2) if f"baseline_s{s}: ttc" not in r["no_peak"] and f"{k}_s{s}: ttc" not in r["no_peak"]]
    if len(peaked) < 2 and c is not None:
        print(f"  {k}: TTC peak change over {c['n']} of 2 seeds (no peak reached: {r['no_peak']})")
    if c is None or c["n"] != len(peaked) or row["changes"]["ttc.ev_end"]["n"] != 2:
        error(f"{k}: TTC changes over the paired seeds missing: {c}")
    elif c["p_holm"] is not None:
        equivalent = c["p_tost"] is not None and c["p_tost"] <= r["alpha"]
        want = "within margin" if equivalent else "changes" if c["p_holm"] <= r["alpha"] else "undecided"
        check(f"{k} TTC peak verdict follows its tests", c["verdict"], want)
    needed = [q for q, c in row["changes"].items() if c and c["verdict"] == "changes"]
    check(f"{k} needed_for", row["needed_for"], needed)
    check(f"{k} verdict", row["verdict"] == "needed", bool(needed))
for q in qs:
    no_peak = all(f"baseline_s{s}: {q.split('.')[0]}" in r["no_peak"] for s in (1, 2))
    if r["noise_floor"][q]["mean"] is None and not (no_peak and q.split(".")[1] in ("peak_ratio", "e1_peak", "b_peak")):
        error(f"no baseline mean of {q}")
check("failed runs", r["failed"], [])
check("runs counted", r["cost"]["runs"], 2 + 3 * 2)
if not r["cost"]["cpu_s"] > 0 or not r["cost"]["wall_s"] > 0:
    error(f"cost missing: {r['cost']}")
md = open(f"{root}/sufficiency.md", encoding="utf-8").read()
for needle in ("# Model sufficiency: ", "| switch | seeds | verdict | TTC peak σ1/σ3 |", "PSC b at peak |",
               "| normal: hertz → linear | — | skipped: normal is linear |",
               "| twisting: marshall → none | — | skipped: twisting is none |",
               "| baseline: mean (noise floor) | 1,2 |", "| rotational damping → 0 | 1,2 |", "Holm",
               "TOST",
               "Cost: 8 runs"):
    if needle not in md:
        error(f"sufficiency.md lacks {needle!r}")
done()
EOF
# A second call finds every run done and runs nothing again.
"$PY" "$ROOT/tools/sufficiency.py" "$ROOT/inputs/paper.json" --out "$out" --seeds 2 --count 100 --end-strain 0.04 \
  --celldem "$CELLDEM" >"$TMP/log2" 2>&1 || fail "second call failed"
grep -q "0 runs to do of 8" "$TMP/log2" || fail "a second call ran again: $(head -1 "$TMP/log2")"

echo "2b. calibration: a switch that changes nothing physical (time_step x (1 + 1e-9)) is never needed"
null="$TMP/sufficiency-null"
"$PY" "$ROOT/tools/sufficiency.py" "$ROOT/inputs/paper.json" --out "$null" --seeds 3 --count 40 --end-strain 0.005 \
  --switches round_off --celldem "$CELLDEM" >"$TMP/log-null" 2>&1 || { cat "$TMP/log-null"; fail "null switch run failed"; }
"$PY" - "$null" <<'EOF' || fail "null switch"
import json, sys
from checking import check, done, error
r = json.load(open(f"{sys.argv[1]}/sufficiency.json"))
rows = {x["key"]: x for x in r["rows"]}
check("rows", sorted(rows), ["baseline", "round_off"])
row = rows["round_off"]
check("seeds", row["seeds"], [1, 2, 3])
if row["verdict"] == "needed":
    error(f"a round-off switch is called needed for {row['needed_for']}")
units = [abs(c["noise_units"]) for c in row["changes"].values() if c and c["noise_units"] is not None]
print(f"  round_off: {row['verdict']}; largest |change| {max(units):.2g} noise floors")
done()
EOF
rm -rf "$null"

echo "3. refusals"
if "$PY" "$ROOT/tools/sufficiency.py" "$ROOT/inputs/paper.json" --out "$TMP/x" --seeds 1 2>/dev/null; then
  fail "one seed accepted (no noise floor)"
fi

echo "4. the study's report includes the sufficiency table found beside the study root"
"$PY" "$ROOT/tests/tools/make_fake_study.py" "$TMP/study" >/dev/null
"$PY" "$ROOT/tools/study.py" analyse --root "$TMP/study" >/dev/null || fail "study.py analyse failed"
grep -q "^## Model sufficiency$" "$TMP/study/study.md" || fail "study.md has no Model sufficiency section"
grep -q "^### Model sufficiency: .*paper.json$" "$TMP/study/study.md" || fail "study.md does not include the table"
grep -q "| normal: hertz → linear | — | skipped: normal is linear |" "$TMP/study/study.md" \
  || fail "study.md lacks the table's rows"
rm -rf "$out"
"$PY" "$ROOT/tools/study.py" analyse --root "$TMP/study" >/dev/null || fail "study.py analyse failed"
if grep -q "Model sufficiency" "$TMP/study/study.md"; then fail "a section without any sufficiency results"; fi

echo "PASS: sufficiency tests"
