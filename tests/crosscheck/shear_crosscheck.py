#!/usr/bin/python3
"""Reduced cross-check of simple shear against LAMMPS fix deform xy (ctest: crosscheck_shear).

Self-contained: prepares the 300-sphere state of small.json with celldem (as program_crosscheck.py does), then
runs one test in celldem and, translated by `celldem translate`, in LAMMPS, both on that state with the deck
matched to LAMMPS's contact model (tools/celldem/crosscheck.py's derived_deck): simple shear, the shear axis
x12 driven at 2e-6 per step to g12 = 1 % (5000 steps; fix deform xy erate on the triclinic box), s22 held at
100 kPa by the servo (LAMMPS: the fix deform variable law, proportional only), e1 = e3 = 0.

Checks (from one realization, small.json as it is: tolerances about twice what it measured, given beside):
  - the tilt: LAMMPS's g12 is celldem's at every common row, within one step's increment (fix deform moves
    the box at the end of a step, so its row shows the tilt one step behind);
  - e1 = e3 = 0 in both codes;
  - the controls as each code held them after g12 = 0.2 %: celldem's s22 within 0.5 % of 100 kPa (PI servo;
    measured 0.05 %), LAMMPS's within 4 % (proportional, nominal stiffness; measured 2.1 %);
  - the shear response: s12 at equal g12 within 4 % of p (measured 0.93 %), and the sample carries the shear
    (s12 above 0.2 p at the end, in both codes; measured 0.50 p).
Prints a table of the measured values and exits 1 when a check fails, 77 (ctest: skipped) without lmp.

usage: shear_crosscheck.py --celldem BIN [--work DIR]
"""
import copy
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from celldem import crosscheck, results

import xc_common  # noqa: E402

DECK = os.path.join(HERE, "small.json")
P = 1.0e5       # s22 held [Pa]
D = 2.0e-6      # g12 per step
STEPS = 5000
SETTLE = 2e-3   # g12 after which the controls are checked

TEST = {"name": "dss", "friction": 0.5, "output_interval": 100,
        "axes": {"x1": {"strain_increment": 0.0}, "x2": {"stress": P}, "x3": {"strain_increment": 0.0},
                 "x12": {"strain_increment": D}},
        "end": {"steps": STEPS}}
TOL = {"tilt_steps": 1.01, "normal": 1e-12, "s22_celldem": 5e-3, "s22_lammps": 4e-2, "s12": 4e-2, "carried": 0.2}


def check(celldem, work, codes):
    state = xc_common.prepare_state(celldem, work, json.load(open(DECK)))
    deck = crosscheck.derived_deck(json.load(open(DECK)), state, [copy.deepcopy(TEST)], "lammps")
    deck_path = os.path.join(work, "shear.json")
    json.dump(deck, open(deck_path, "w"), indent=2)
    subprocess.run([celldem, "run", deck_path, "--out", os.path.join(work, "celldem"), "--threads", "1", "--quiet"],
                   check=True)
    subprocess.run([celldem, "translate", deck_path, "--to", "lammps", "--out", work], check=True, capture_output=True)
    subprocess.run(["lmp", "-in", "dss.lammps.in", "-log", "log.lammps", "-screen", "none"], cwd=work, check=True)
    ref = results.load_series(os.path.join(work, "celldem", "dss", "series.csv"))
    lmp = results.load_series(os.path.join(work, "dss.lammps.csv"))
    _, first = np.unique(lmp["step"], return_index=True)
    lmp = {k: v[np.sort(first)] for k, v in lmp.items()}

    common, i_ref, i_lmp = np.intersect1d(ref["step"], lmp["step"], return_indices=True)
    checks = []  # (what, celldem, LAMMPS, measured, tolerance)
    tilt = float(np.max(np.abs(ref["g12"][i_ref] - lmp["g12"][i_lmp]))) / D
    checks.append(("g12 at equal steps (%d rows), in steps' increments" % len(common),
                   float(ref["g12"][-1]), float(lmp["g12"][-1]), tilt, TOL["tilt_steps"]))
    normal = max(float(np.max(np.abs(s[k]))) for s in (ref, lmp) for k in ("e1", "e3"))
    checks.append(("max |e1|, |e3| in both", None, None, normal, TOL["normal"]))
    s22_ref = float(np.max(np.abs(ref["s22"][ref["g12"] >= SETTLE] / P - 1.0)))
    s22_lmp = float(np.max(np.abs(lmp["s22"][lmp["g12"] >= SETTLE] / P - 1.0)))
    checks.append(("celldem max |s22/p* - 1| after g12 = %g" % SETTLE, s22_ref, None, s22_ref, TOL["s22_celldem"]))
    checks.append(("LAMMPS max |s22/p* - 1| after g12 = %g" % SETTLE, None, s22_lmp, s22_lmp, TOL["s22_lammps"]))
    order = np.argsort(lmp["g12"])
    keep = (ref["g12"] >= SETTLE) & (ref["g12"] <= lmp["g12"][order][-1])
    at = np.interp(ref["g12"][keep], lmp["g12"][order], lmp["s12"][order])
    s12 = float(np.max(np.abs(at - ref["s12"][keep]))) / P
    checks.append(("s12 at equal g12 (%d rows), / p" % int(keep.sum()), float(ref["s12"][-1]), float(lmp["s12"][-1]),
                   s12, TOL["s12"]))
    carried = min(float(ref["s12"][-1]), float(lmp["s12"][-1])) / P
    checks.append(("s12 / p at the end, the smaller of the two (at least)", None, None, -carried, -TOL["carried"]))

    print("\ncelldem vs LAMMPS, simple shear (g12 to %g at %g per step, s22 = %g Pa)" % (D * STEPS, D, P))
    print("%-58s %14s %14s %11s %9s  %s" % ("check", "celldem", "LAMMPS", "measured", "tolerance", ""))
    ok = True
    for what, a, b, diff, tol in checks:
        good = diff <= tol
        ok = ok and good
        fmt = lambda v: "" if v is None else "%.6g" % v  # noqa: E731
        print("%-58s %14s %14s %11.3g %9.3g  %s" % (what, fmt(a), fmt(b), diff, tol, "pass" if good else "FAIL"))
    print("(the last row is negated: it passes when s12/p is at least %g)" % TOL["carried"])
    return 0 if ok else 1


def main():
    return xc_common.main_for_codes("celldem-shear-xc-", check)


if __name__ == "__main__":
    sys.exit(main())
