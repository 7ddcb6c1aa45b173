#!/usr/bin/python3
"""A deck resolved by --tolerance, translated and run in LAMMPS (ctest: crosscheck_stages).

Self-contained: prepares the 300-sphere state of small.json with celldem, runs its TTC and a simple shear that
ends on its shear strain (g12 = 0.3 %) from that state with `celldem run --tolerance 1` (the resolved deck gives
each test its own time step, tests[].time_step, not the deck's), translates the run's resolved_deck.json with
`celldem translate` and runs both tests' scripts in LAMMPS.

Checks:
  - the resolved deck's test runs at a time step other than the deck's (else this checks nothing);
  - the script sets that time step before its run, and LAMMPS runs celldem's number of steps (the log's
    "for N steps");
  - the series' time is step x the stage's time step in both codes;
  - e1 at every common row is celldem's within one step's increment (fix deform moves the box at the end of a
    step), i.e. fix deform's erate was made from the stage's time step;
  - the simple shear: LAMMPS runs celldem's steps to g12 = 0.3 % (its run N from the shear strain end) and g12
    at every common row is celldem's within one step's increment.
Prints a table and exits 1 when a check fails, 77 (ctest: skipped) without lmp.

usage: stages_crosscheck.py --celldem BIN [--work DIR]
"""
import copy
import json
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from celldem import crosscheck, results

import xc_common  # noqa: E402

DECK = os.path.join(HERE, "small.json")


def check(celldem, work, codes):
    written = json.load(open(DECK))
    state = xc_common.prepare_state(celldem, work, written)
    test = copy.deepcopy(written["tests"][0])
    test["end"]["strain"] = 0.003
    shear = {"name": "dss", "friction": 0.5, "output_interval": 100,
             "simple_shear": {"gamma_increment": 2.0e-7, "normal_stress": 1.0e5}, "end": {"axis": "x12", "strain": 0.003}}
    deck = crosscheck.derived_deck(written, state, [test, shear], "lammps")
    deck_path = os.path.join(work, "stages.json")
    json.dump(deck, open(deck_path, "w"), indent=2)
    run = os.path.join(work, "celldem")
    subprocess.run([celldem, "run", deck_path, "--out", run, "--tolerance", "1", "--threads", "1", "--quiet",
                    "--force"], check=True)
    resolved = json.load(open(os.path.join(run, "resolved_deck.json")))
    dt = resolved["tests"][0].get("time_step", resolved["time_step"])
    subprocess.run([celldem, "translate", os.path.join(run, "resolved_deck.json"), "--to", "lammps", "--out", work, "--force"], check=True, capture_output=True)
    script = open(os.path.join(work, "ttc.lammps.in")).read()
    for name in ("ttc", "dss"):
        subprocess.run(["lmp", "-in", name + ".lammps.in", "-log", name + ".log", "-screen", "none"], cwd=work,
                       check=True)
    ref = results.load_series(os.path.join(run, "ttc", "series.csv"))
    lmp = results.load_series(os.path.join(work, "ttc.lammps.csv"))
    lammps_steps = int(re.findall(r"for (\d+) steps", open(os.path.join(work, "ttc.log")).read())[-1])
    ref_dss = results.load_series(os.path.join(run, "dss", "series.csv"))
    lmp_dss = results.load_series(os.path.join(work, "dss.lammps.csv"))
    dss_steps = int(re.findall(r"for (\d+) steps", open(os.path.join(work, "dss.log")).read())[-1])
    gamma = resolved["tests"][1]["simple_shear"]["gamma_increment"]
    shared, j_ref, j_lmp = np.intersect1d(ref_dss["step"], lmp_dss["step"], return_indices=True)
    timestep = float(re.search(r"^timestep\s+(\S+)", script, re.M).group(1))
    increment = resolved["tests"][0]["axes"]["x1"]["strain_increment"]

    common, i_ref, i_lmp = np.intersect1d(ref["step"], lmp["step"], return_indices=True)
    checks = [  # (what, celldem, LAMMPS, measured, tolerance): passes when measured <= tolerance
        ("the test's time step differs from the deck's (|dt/dt_deck - 1|, at least 0.1)", dt, None,
         -abs(dt / resolved["time_step"] - 1.0), -0.1),
        ("the script's timestep is the stage's (relative difference)", dt, timestep, abs(timestep / dt - 1.0), 0.0),
        ("steps run (difference)", float(ref["step"][-1]), float(lammps_steps),
         abs(lammps_steps - ref["step"][-1]), 0.0),
        ("time = step x dt, celldem (largest relative difference)", None, None,
         float(np.max(np.abs(ref["time"][1:] / (ref["step"][1:] * dt) - 1.0))), 1e-9),
        ("time = step x dt, LAMMPS (largest relative difference)", None, None,
         float(np.max(np.abs(lmp["time"][1:] / (lmp["step"][1:] * dt) - 1.0))), 1e-9),
        ("e1 at equal steps (%d rows), in steps' increments" % len(common), float(ref["e1"][-1]), float(lmp["e1"][-1]),
         float(np.max(np.abs(ref["e1"][i_ref] - lmp["e1"][i_lmp]))) / increment, 1.01),
        ("simple shear to g12 = 0.003: steps run (difference)", float(ref_dss["step"][-1]), float(dss_steps),
         abs(dss_steps - ref_dss["step"][-1]), 0.0),
        ("simple shear: celldem's g12 at its end, from 0.003, in steps' increments", float(ref_dss["g12"][-1]), None,
         abs(ref_dss["g12"][-1] - 0.003) / gamma, 0.5),
        ("simple shear: g12 at equal steps (%d rows), in steps' increments" % len(shared), float(ref_dss["g12"][-1]),
         float(lmp_dss["g12"][-1]), float(np.max(np.abs(ref_dss["g12"][j_ref] - lmp_dss["g12"][j_lmp]))) / gamma, 1.01),
    ]
    print("\ncelldem vs LAMMPS, a test at its own time step (resolved by --tolerance 1)")
    print("%-78s %12s %12s %11s %9s" % ("check", "celldem", "LAMMPS", "measured", "tolerance"))
    ok = len(common) >= 3 and len(shared) >= 3
    for what, a, b, diff, tol in checks:
        good = diff <= tol
        ok = ok and good
        fmt = lambda v: "" if v is None else "%.6g" % v  # noqa: E731
        print("%-78s %12s %12s %11.3g %9.3g  %s" % (what, fmt(a), fmt(b), diff, tol, "pass" if good else "FAIL"))
    print("(a negated row passes when the quantity is at least the tolerance's magnitude)")
    return 0 if ok else 1


def main():
    return xc_common.main_for_codes("celldem-stages-xc-", check)


if __name__ == "__main__":
    sys.exit(main())
