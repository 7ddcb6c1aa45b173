#!/usr/bin/python3
"""A worked example of celldem's Python API: prepare a small sample, run a stress path (triaxial compression at a
constant confining stress) with a set of stress probes part-way, and plot both with pandas and matplotlib.

Usage: /usr/bin/python3 docs/examples/stress_path_and_probes.py [--out results/example] [--count 300]
       (from a checkout, with tools/ on PYTHONPATH, or with the package installed: docs/python.md)

Writes OUT/run/ (the run folder), OUT/stress_path.png (σ1/σ3 and the volumetric strain against ε1) and
OUT/probe_responses.png (each probe's stress increment and strain response in the Rendulic plane). About 20 s
on one core at 300 spheres.
"""

import argparse
import math
import os

import matplotlib

matplotlib.use("Agg")  # files only, no window
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

import celldem  # noqa: E402

CONFINING = 1.0e5  # [Pa] the confining stress of the preparation and of the test


def build_deck(count: int) -> celldem.Deck:
    """A deck written here in full: polydisperse spheres, linear contacts, an isotropic preparation to
    CONFINING, then triaxial compression to ε1 = 0.4 % with stress probes at ε1 = 0.2 %."""
    return celldem.Deck.from_dict({
        "format": 1,
        "sample": {"count": count, "diameters": {"min": 0.003, "max": 0.0045, "count": 4}, "density": 2650,
                   "seed": 11, "grid_spacing": 0.005},
        "contact": {"kn": 1e6, "kt": 1e6},
        "damping": {"translational": 0.05, "rotational": 0.05},
        "time_step": 1e-6,
        "prepare": {"target_pressure": CONFINING, "fast_strain_increment": 5e-5, "output_interval": 500,
                    "equilibrium": {"min_steps": 2000, "max_steps": 200000, "unbalanced_force_ratio": 0.02,
                                    "check_interval": 500}},
        "tests": [{
            "name": "ttc", "friction": 0.5,
            "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": CONFINING}, "x3": {"stress": CONFINING}},
            "end": {"axis": "x1", "strain": 0.004}, "output_interval": 250,
            # Four stress increments of 4 kPa in the Rendulic plane (ds11, ds22 = ds33), each loaded, held and
            # unloaded from the test's state at ε1 = 0.2 % (docs/outputs.md#probes).
            "probes": {"at_e1": [0.002], "kind": "stress", "plane": "rendulic", "directions": 4,
                       "magnitudes": [4000], "steps": 1500, "hold_steps": 500},
        }],
    })


def plot_stress_path(run: celldem.Run, path: str) -> None:
    """σ1/σ3 and εv against ε1, from the test's series (a pandas DataFrame; df.attrs["units"] has the units)."""
    df = run.tests["ttc"].series
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(5, 6))
    top.plot(df["e1"] * 100, df["s11"] / df["s33"])
    top.set_ylabel("σ1/σ3 (–)")
    bottom.plot(df["e1"] * 100, df["ev"] * 100)
    bottom.set_ylabel("εv (%)")
    bottom.set_xlabel("ε1 (%)")
    peak = run.tests["ttc"].summary.get("peak_ratio13")
    top.set_title(f"triaxial compression at {CONFINING / 1e3:g} kPa" + (f", peak σ1/σ3 {peak:.3f}" if peak else ""))
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def probe_table(run: celldem.Run) -> pd.DataFrame:
    """ttc/probes/probes.csv as a DataFrame, with each probe's increments in the Rendulic plane's coordinates
    (ds11, √2 ds33; de1, √2 de3)."""
    df = pd.read_csv(os.path.join(run.tests["ttc"].path, "probes", "probes.csv"))
    df["ds_axial"], df["ds_radial"] = df["ds11"], math.sqrt(2.0) * df["ds33"]
    df["de_axial"], df["de_radial"] = df["de1"], math.sqrt(2.0) * df["de3"]
    return df


def plot_probes(table: pd.DataFrame, path: str) -> None:
    fig, (left, right) = plt.subplots(1, 2, figsize=(9, 4.5))
    for _, r in table.iterrows():
        left.annotate("", (r["ds_radial"] / 1e3, r["ds_axial"] / 1e3), (0, 0), arrowprops={"arrowstyle": "->"})
        right.annotate("", (r["de_radial"] * 1e6, r["de_axial"] * 1e6), (0, 0), arrowprops={"arrowstyle": "->"})
    for ax, scale, unit in ((left, 1e-3, "kPa"), (right, 1e6, "1e-6")):
        cols = ("ds_radial", "ds_axial") if ax is left else ("de_radial", "de_axial")
        reach = max(abs(table[c] * scale).max() for c in cols) * 1.2
        ax.set_xlim(-reach, reach)
        ax.set_ylim(-reach, reach)
        ax.set_aspect("equal")
        ax.axhline(0, color="0.7", linewidth=0.5)
        ax.axvline(0, color="0.7", linewidth=0.5)
    left.set(xlabel="√2 Δσ3 (kPa)", ylabel="Δσ1 (kPa)", title="stress probes (Rendulic plane)")
    right.set(xlabel="√2 Δε3 (1e-6)", ylabel="Δε1 (1e-6)", title="their strain responses")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join("results", "example"), help="output folder")
    parser.add_argument("--count", type=int, default=300, help="spheres (default 300)")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    deck = build_deck(args.count)
    print(celldem.check_deck(deck).strip())
    run = celldem.run_deck(deck, os.path.join(args.out, "run"), threads=args.threads, force=True)
    assert isinstance(run, celldem.Run)
    plot_stress_path(run, os.path.join(args.out, "stress_path.png"))
    table = probe_table(run)
    plot_probes(table, os.path.join(args.out, "probe_responses.png"))
    print(table[["probe", "magnitude", "ds11", "ds33", "de1", "de3", "controlled"]].to_string(index=False))
    print(f"wrote {args.out}/stress_path.png and {args.out}/probe_responses.png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
