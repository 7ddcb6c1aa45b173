#!/usr/bin/python3
"""Reduced cross-check of celldem against LAMMPS and LIGGGHTS (ctest: crosscheck_reduced, crosscheck_mpi).

Self-contained: prepares its own 300-sphere state with celldem (small.json without its tests) in a
temporary folder, then
  default: crosscheck/run_crosscheck.py on small.json with that state, both codes, both kinds of scene:
           (a) constant-volume strain scene to e1 = 0.3 %: relative stress difference < 1e-3 up to e1 = 0.2 %
               (LAMMPS; measured 4e-5) and 0.1 % (LIGGGHTS; measured 2e-4: without rotational damping
               its dynamics are chaotic and differences grow ~30x per 0.04 % of strain);
           (b) the TTC test to e1 = 0.8 % (paper rate), in summary.json's quantities (celldem's own; the other
               code's computed from its series by the same definitions): max s11/s33 within 3 % (measured
               0.3-0.5 %), ev at the end (0.8 %) within 5e-4 (measured 2e-5; LIGGGHTS 1 vs 2 ranks: 9e-5), Z over
               the end window (e1 0.3-0.8 %) within 0.1, e1 at the peak (the centre of the range within 1 % of
               the max, which lies on a flat, noisy plateau) within 0.5 %.
  --mpi:   translates the TTC test (shortened to e1 = 0.2 %) for LAMMPS and runs the same script with
           `lmp` and with `mpirun -np 2 lmp`; every row must agree to 1e-6 (lengths and stresses) and
           to 2 in the contact count.
The default run also checks that `celldem summarize` (used for the other codes' series) gives, on celldem's own
series as written to series.csv, exactly what celldem wrote in summary.json.
Exit 77 (ctest: skipped) when lmp, liggghts or mpirun is missing.

usage: reduced_crosscheck.py --celldem BIN [--mpi] [--work DIR]
"""
import argparse
import copy
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
import run_crosscheck  # noqa: E402
from celldem import binary, crosscheck, results

import xc_common  # noqa: E402

DECK = os.path.join(HERE, "small.json")


def prepare(celldem, work):
    with open(DECK) as f:
        return xc_common.prepare_state(celldem, work, json.load(f))


def reduced(celldem, work, state):
    rc = run_crosscheck.main([
        DECK, "--state", state, "--out", os.path.join(work, "xc"), "--celldem", celldem, "--threads", "1",
        "--strain-end", "0.003", "--hold-e1", "lammps=0.002,liggghts=0.001", "--tol-stress", "1e-3",
        "--tol-peak", "0.03", "--tol-e1-peak", "0.005", "--tol-ev", "5e-4", "--tol-z", "0.1"])
    for code in ("lammps", "liggghts"):
        rc |= summarize_agrees(os.path.join(work, "xc", code, "celldem"))
    return rc


def summarize_agrees(run_dir):
    """`celldem summarize` on each test series of a celldem run equals that run's summary.json (0), or 1."""
    run = results.load_run(run_dir)
    bad = []
    for test in run.test_names:
        for key, value in binary.summarize(os.path.join(run_dir, test, "series.csv"), "x1").items():
            if value != run.test_summary(test).get(key):
                bad.append("%s %s: summarize %r, summary.json %r" % (test, key, value, run.test_summary(test).get(key)))
    print("celldem summarize against celldem's summary.json (%s): %s" % (run_dir, "; ".join(bad) or "same"))
    return 1 if bad else 0


def mpi(celldem, work, state):
    deck = json.load(open(DECK))
    test = copy.deepcopy(deck["tests"][0])
    test["end"]["strain"] = 0.002
    deck = crosscheck.derived_deck(deck, state, [test], "lammps")
    folder = os.path.join(work, "mpi")
    os.makedirs(folder)
    json.dump(deck, open(os.path.join(folder, "deck.json"), "w"), indent=2)
    subprocess.run([celldem, "translate", os.path.join(folder, "deck.json"), "--to", "lammps", "--out", folder],
                   check=True, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
    script = "%s.lammps.in" % test["name"]
    base = ["lmp", "-in", script, "-screen", "none"]
    subprocess.run(base + ["-var", "out", "np1.csv", "-log", "np1.log"], cwd=folder, check=True)
    subprocess.run(["mpirun", "-np", "2"] + base + ["-var", "out", "np2.csv", "-log", "np2.log"], cwd=folder,
                   check=True, env=crosscheck.mpi_env())
    a = results.load_series(os.path.join(folder, "np1.csv"))
    b = results.load_series(os.path.join(folder, "np2.csv"))
    if len(a["step"]) != len(b["step"]) or len(a["step"]) < 2 or (a["step"] != b["step"]).any():
        print("FAIL: the single-rank and two-rank series have different rows")
        return 1
    rel = max(float(np.max(np.abs(a[k] / b[k] - 1.0))) for k in ("l1", "l2", "l3", "s11", "s22", "s33"))
    dn = float(np.max(np.abs(a["n_contacts"] - b["n_contacts"])))
    ok = rel < 1e-6 and dn <= 2
    print("mpirun -np 2 versus 1 rank, %d rows to step %d: max relative difference %.2e (tolerance 1e-6), "
          "contact count %d (tolerance 2): %s" % (len(a["step"]), a["step"][-1], rel, dn, "pass" if ok else "FAIL"))
    return 0 if ok else 1


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--celldem", required=True)
    p.add_argument("--mpi", action="store_true")
    p.add_argument("--work", help="keep the files in this folder (default: a temporary folder)")
    args = p.parse_args()
    xc_common.need("lmp", "mpirun") if args.mpi else xc_common.need("lmp", "liggghts")
    celldem = os.path.abspath(args.celldem)

    def check(work):
        state = prepare(celldem, work)
        rc = mpi(celldem, work, state) if args.mpi else reduced(celldem, work, state)
        if rc == 0 and not args.mpi:
            print(open(os.path.join(work, "xc", "report.md")).read())
        return rc

    return xc_common.in_work_folder(args.work, "celldem-xc-", check)


if __name__ == "__main__":
    sys.exit(main())
