#!/usr/bin/env python3
"""For crosscheck/yade_energy.sh. `yade_packing.py RUN STEPS`: the start of the run's test `strain` (its ascii
snapshot at step 0: cell, radii, positions, fluctuating velocities, spins, and the deck's physics) as the JSON
crosscheck/yade_energy.py reads, on stdout. `yade_packing.py --compare RUN YADE.json`: the two codes' energy
partitions over the test side by side (celldem's from the last row of its series)."""
import csv
import json
import os
import re
import sys

import numpy as np


def arrays(vtu):
    text = open(vtu).read()
    out = {}
    for m in re.finditer(r'<DataArray([^>]*)>(.*?)</DataArray>', text, re.S):
        name = re.search(r'Name="(\w+)"', m.group(1))
        out.setdefault(name.group(1) if name else "points", np.array(m.group(2).split(), dtype=float))
    return out


def packing(run, steps):
    deck = json.load(open(os.path.join(run, "..", "test.json")))
    test = deck["tests"][0]
    a = arrays(os.path.join(run, "strain", "snapshots", "strain_0.vtu"))
    h = a["cell_h"].reshape(3, 3)
    rate = [test["axes"][f"x{k}"]["strain_increment"] / deck["time_step"] for k in (1, 2, 3)]
    L = np.diag([-r for r in rate])  # compression positive increments shorten the axes
    x = a["points"].reshape(-1, 3)
    v = a["velocity"].reshape(-1, 3) + x @ L.T  # YADE's velocities are whole: the affine field added
    radius = a["radius"]
    assert np.ptp(radius) == 0, "equal spheres only (YADE's FrictPhys then has celldem's kn)"
    return {"h": h.tolist(), "radius": float(radius[0]), "positions": x.tolist(), "velocities": v.tolist(),
            "spins": a["spin"].reshape(-1, 3).tolist(), "kn": deck["contact"]["kn"], "kt": deck["contact"]["kt"],
            "mu": test["friction"], "density": deck["sample"]["density"], "dt": deck["time_step"],
            "velocity_gradient": L.tolist(), "steps": steps}


def compare(run, yade_json):
    rows = list(csv.DictReader(open(os.path.join(run, "strain", "series.csv"))))
    first, last = rows[0], rows[-1]
    f = lambda r, *names: sum(float(r[n]) for n in names)
    y = json.load(open(yade_json))
    ys, ye = y["start"], y["end"]
    table = [
        ("boundary work", f(last, "energy_boundary_work") - f(first, "energy_boundary_work"), y["boundary_work"]),
        ("stored (end - start)", f(last, "energy_normal", "energy_tangential") - f(first, "energy_normal", "energy_tangential"),
         ye.get("elastPotential", 0.0) - ys.get("elastPotential", 0.0)),
        ("friction", f(last, "energy_friction") - f(first, "energy_friction"),
         ye.get("plastDissip", float("nan")) - ys.get("plastDissip", 0.0)),
        ("work - stored - kinetic", f(last, "energy_boundary_work") - f(first, "energy_boundary_work")
         - (f(last, "energy_normal", "energy_tangential", "energy_kinetic_translation", "energy_kinetic_rotation")
            - f(first, "energy_normal", "energy_tangential", "energy_kinetic_translation", "energy_kinetic_rotation")),
         y["boundary_work"] - (ye["elastPotential"] - ys["elastPotential"]) - (ye["kinetic"] - ys["kinetic"])),
        ("kinetic at the end", f(last, "energy_kinetic_translation", "energy_kinetic_rotation"),
         y["kinetic_fluctuating"] + y["kinetic_rotation"]),
    ]
    print(f"{'term':24s} {'celldem [J]':>14s} {'YADE [J]':>14s} {'YADE/celldem - 1':>18s}")
    for name, c, yv in table:
        print(f"{name:24s} {c:14.6g} {yv:14.6g} {yv / c - 1 if c else float('nan'):18.3g}")
    print(f"YADE's own kinetic (whole velocities) at the end: {ye.get('kinetic', float('nan')):.6g} J")


if __name__ == "__main__":
    if sys.argv[1] == "--compare":
        compare(sys.argv[2], sys.argv[3])
    else:
        json.dump(packing(sys.argv[1], int(sys.argv[2])), sys.stdout)
