#!/usr/bin/python3
"""Strain probes against LAMMPS (ctest: crosscheck_probes): the elastic stiffness that celldem's probes measure
on a frictionless packing, measured again by LAMMPS from the same state through the translator.

Self-contained: prepares the 300-sphere frictionless state of small.json (isotropic, 100 kPa), then in celldem a
hold (every strain held, 50,000 steps: the packing settles) with strain probes at its end (`probes`: e11, e22, e33, g12, g13, g23,
M = 1e-5 over 1000 steps, held 500, unloaded, held 500; the deck matched to LAMMPS's contact model). The probe
point's rested state (`hold/probes/end/rest/rested.state`, where its probes start) becomes the initial state of a deck whose tests are the same
probes' load programs written out as legs (and the reference, every strain held), translated to LAMMPS and run
there. Frictionless, so that nothing the data file cannot carry (tangential contact history) matters.

Checks: for each probe, LAMMPS's net stress increments (the normal ones of the normal probes: their scripts keep
the box orthogonal and write no shear stresses; all six of the shear probes) at the end of the loaded hold (the probe's stresses less
the reference's at the same step) against celldem's probes.csv (ds11..ds23): every component within 2 % of the
probe's largest (the two codes' trajectories part by round-off; measured 0.01-0.02 % for the normal strains,
0.2-0.6 % for the shear ones, whose response is 30 times smaller: a frictionless packing near jamming has a
shear modulus far below its bulk modulus), and celldem's elastic stiffness symmetric within 5 % (measured 2.3 %:
its shear entries are a few percent of the normal ones, so their noise weighs). Exits 1 when a check fails, 77 (ctest: skipped) without lmp.

usage: probe_crosscheck.py --celldem BIN [--work DIR]
"""
import csv
import json
import os
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from celldem import crosscheck, results

import xc_common  # noqa: E402

DECK = os.path.join(HERE, "small.json")
M = 1.0e-5
STEPS, HOLD = 1000, 500
STRAINS = ("e11", "e22", "e33", "g12", "g13", "g23")
STRESSES = ("s11", "s22", "s33", "s12", "s13", "s23")
TOL = {"increment": 0.02, "symmetry": 0.05}
HELD = {"x1": {"strain_increment": 0.0}, "x2": {"strain_increment": 0.0}, "x3": {"strain_increment": 0.0}}
HOLD_TEST = {"name": "hold", "friction": 0.0, "axes": HELD, "end": {"steps": 50000}, "output_interval": 5000,
             "probes": {"at": ["end"], "kind": "strain", "magnitudes": [M], "steps": STEPS, "hold_steps": HOLD}}


def probe_legs(strain, tilted=False):
    """The probe's load program as run/probes.cpp builds it: load by M over STEPS, hold, unload, hold. `tilted`:
    a reference whose x12 moves by 1e-30 per step (3e-27 in all, far below the round-off of the box), so that its
    translated script runs on a triclinic box and writes the shear stresses, as the shear probes' scripts do."""
    legs = []
    for sign, steps in ((1, STEPS), (0, HOLD), (-1, STEPS), (0, HOLD)):
        axes = {k: dict(v) for k, v in HELD.items()}
        per_step = sign * M / STEPS if strain else 0.0
        if strain in ("e11", "e22", "e33"):
            axes["x" + strain[1]] = {"strain_increment": per_step}
        elif strain:
            axes["x" + strain[1:]] = {"strain_increment": per_step}
        if tilted:
            axes["x12"] = {"strain_increment": 1e-30}
        legs.append({"axes": axes, "end": {"steps": steps}})
    return legs


def stresses_at(series, step, names):
    i = int(np.flatnonzero(series["step"] == step)[-1])
    return np.array([series[s][i] for s in names])


def check(celldem, work, codes):
    state = xc_common.prepare_state(celldem, work, json.load(open(DECK)))
    deck = crosscheck.derived_deck(json.load(open(DECK)), state, [json.loads(json.dumps(HOLD_TEST))], "lammps")
    deck_path = os.path.join(work, "probed.json")
    json.dump(deck, open(deck_path, "w"), indent=2)
    out = os.path.join(work, "celldem")
    subprocess.run([celldem, "run", deck_path, "--out", out, "--threads", "1", "--quiet", "--force"], check=True)
    with open(os.path.join(out, "hold", "probes", "probes.csv")) as f:
        ours = {r["probe"]: r for r in csv.DictReader(f)}
    # The probes start from the point after its rest (rest/rested.state; docs/outputs.md)
    point_state = os.path.join(out, "hold", "probes", "end", "rest", "rested.state")

    tests = [{"name": "reference", "friction": 0.0, "legs": probe_legs(None), "output_interval": HOLD},
             {"name": "reference_tilted", "friction": 0.0, "legs": probe_legs(None, True), "output_interval": HOLD}]
    tests += [{"name": s, "friction": 0.0, "legs": probe_legs(s), "output_interval": HOLD} for s in STRAINS]
    lmp_deck = crosscheck.derived_deck(json.load(open(DECK)), point_state, tests, "lammps")
    lmp_path = os.path.join(work, "probes_lammps.json")
    json.dump(lmp_deck, open(lmp_path, "w"), indent=2)
    subprocess.run([celldem, "translate", lmp_path, "--to", "lammps", "--out", work, "--force"], check=True, capture_output=True)
    series = {}
    for t in tests:
        subprocess.run(["lmp", "-in", t["name"] + ".lammps.in", "-log", t["name"] + ".log", "-screen", "none"],
                       cwd=work, check=True)
        series[t["name"]] = results.load_series(os.path.join(work, t["name"] + ".lammps.csv"))
    first = float(series["reference"]["step"][0])
    loaded = first + STEPS + HOLD

    print("\ncelldem probes vs LAMMPS from the probe point's state (frictionless, M = %g, net of the reference)" % M)
    print("%-6s %-40s %-40s %9s %9s  %s" % ("probe", "celldem ds11..ds23 [Pa]", "LAMMPS [Pa]", "measured", "tolerance", ""))
    ok = True
    elastic = np.zeros((6, 6))
    for j, s in enumerate(STRAINS):
        # The normal probes' scripts keep the box orthogonal and write the normal stresses only; the shear
        # probes' are triclinic, with the shear stresses, against the tilted reference.
        names = [c for c in STRESSES if c in series[s]]
        reference = series["reference_tilted" if s.startswith("g") else "reference"]
        mine = np.array([float(ours[s]["d" + c]) for c in names])
        theirs = stresses_at(series[s], loaded, names) - stresses_at(reference, loaded, names)
        diff = float(np.max(np.abs(mine - theirs)) / np.max(np.abs(mine)))
        good = diff <= TOL["increment"]
        ok = ok and good
        print("%-6s %-40s %-40s %9.3g %9.3g  %s" % (s + ("" if len(names) == 6 else " (normal)"), " ".join("%.4g" % x for x in mine),
                                                   " ".join("%.4g" % x for x in theirs), diff, TOL["increment"],
                                                   "pass" if good else "FAIL"))
        elastic[:, j] = [(float(ours[s]["d" + c]) - float(ours[s]["d" + c + "_residual"])) / M for c in STRESSES]
    asym = float(np.linalg.norm(elastic - elastic.T) / np.linalg.norm(elastic))
    good = asym <= TOL["symmetry"]
    ok = ok and good
    print("celldem elastic stiffness asymmetry |C - C^T| / |C|: %.3g (tolerance %g)  %s"
          % (asym, TOL["symmetry"], "pass" if good else "FAIL"))
    return 0 if ok else 1


def main():
    return xc_common.main_for_codes("celldem-probe-xc-", check)


if __name__ == "__main__":
    sys.exit(main())
