#!/usr/bin/env python3
"""The energy budget's closure error against the time step (docs/energy.md): small_run.json's sample prepared
once, then its TTC from that state at fractions of the stability limit t_c, at one strain rate (the strain
increment per step scaled with the step), `dynamic` so that nothing stops a boiling packing, with the deck's
damping or none. Writes a CSV and a figure of the worst |closure| / boundary work against dt / t_c.

    tools/energy_sweep.py --celldem build/celldem --out /tmp/sweep [--figure docs/figures/energy_dt_sweep.png]
"""
import argparse
import csv
import json
import os
import subprocess

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
DECK = os.path.join(HERE, "..", "tests", "run", "small_run.json")
FRACTIONS = (0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 0.92)


def run(celldem, deck, out):
    path = out + ".json"
    with open(path, "w") as f:
        json.dump(deck, f)
    subprocess.run([celldem, "run", path, "--out", out, "--force", "--quiet", "--threads", "1"], check=True)
    return json.load(open(os.path.join(out, "summary.json")))


def stability_limit(celldem, deck_path):
    plan = json.loads(subprocess.run([celldem, "plan", deck_path, "--json"], check=True, capture_output=True,
                                     text=True).stdout)
    return plan["critical_time_step"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--celldem", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--figure")
    ap.add_argument("--strain", type=float, default=0.003)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    base = json.load(open(DECK))
    base["energy_budget"] = True
    prep = dict(base, tests=[])
    run(args.celldem, prep, os.path.join(args.out, "prep"))
    state = os.path.join(args.out, "prep", "prepared.state")
    t_c = stability_limit(args.celldem, os.path.join(args.out, "prep.json"))
    rate = base["tests"][0]["axes"]["x1"]["strain_increment"] / base["time_step"]  # [1/s]
    rows = []
    for damping in ("deck", "none"):
        for frac in FRACTIONS:
            deck = json.loads(json.dumps(base))
            deck.pop("prepare")
            deck["initial_state"] = state
            if damping == "none":
                deck["damping"] = {"translational": 0.0, "rotational": 0.0}
            deck["time_step"] = frac * t_c
            ttc = deck["tests"][0]
            ttc["axes"]["x1"]["strain_increment"] = rate * frac * t_c
            ttc["end"]["strain"] = args.strain
            ttc["dynamic"] = True
            ttc["output_interval"] = max(1, int(round(250 * base["time_step"] / (frac * t_c))))
            deck["tests"] = [ttc]
            name = f"ttc_{damping}_{frac:g}"
            summary = run(args.celldem, deck, os.path.join(args.out, name))
            e = summary["tests"]["ttc"]["energy"]
            rows.append({"damping": damping, "dt_over_tc": frac, "dt": frac * t_c,
                         "worst_closure_relative": e["worst_closure_relative"],
                         "closure_relative": e["closure_relative"], "damping_share": e["damping_share"],
                         "boundary_work": e["boundary_work"]})
            print(rows[-1], flush=True)
    with open(os.path.join(args.out, "energy_dt_sweep.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    if args.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(5.6, 4.0))
        for damping, marker in (("deck", "o"), ("none", "s")):
            pts = [(r["dt_over_tc"], abs(r["worst_closure_relative"])) for r in rows if r["damping"] == damping]
            x, y = np.array(pts).T
            ax.loglog(x, y, marker=marker, label=f"damping: {damping}")
        ax.set_xlabel("time step / stability limit t_c")
        ax.set_ylabel("worst |closure| / boundary work")
        ax.set_title("Energy closure against the time step (150 spheres, TTC)", fontsize=10)
        ax.grid(True, which="both", linewidth=0.4, alpha=0.5)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(args.figure, dpi=120)


if __name__ == "__main__":
    main()
