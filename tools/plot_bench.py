#!/usr/bin/env python3
"""Scaling table and plot from `celldem bench --scaling` output.

Usage: /usr/bin/python3 tools/plot_bench.py BENCH_DIR   (reads BENCH_DIR/bench.json, writes scaling.png and
scaling.md beside it)
"""
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = Path(argv[1])
    path = folder / "bench.json"
    if not path.is_file():
        print(f"plot_bench: {path} not found (run celldem bench --scaling --out {folder})", file=sys.stderr)
        return 2
    bench = json.loads(path.read_text())
    rows = bench.get("scaling", [])
    lines = ["| particles | threads | steps | particle-steps/s | bytes/particle |", "|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['particles']} | {r['threads']} | {r['steps']} | {r['particle_steps_per_s']:.3g} | "
                     f"{r['bytes_per_particle']:.0f} |")
    medians = bench.get("median_particle_steps_per_s", {})
    lines += ["", "| run | median particle-steps/s |", "|---|---:|"]
    lines += [f"| {k} | {v:.3g} |" for k, v in sorted(medians.items())]
    if "ratio" in bench:
        lines += ["", f"ratio (celldem, most threads / LAMMPS, most ranks): {bench['ratio']:.2f}"]
    if bench.get("step_seconds"):
        lines += ["", f"one series row costs {bench['row_seconds']:.3g} s = "
                      f"{bench['row_seconds'] / bench['step_seconds']:.2f} steps"]
    (folder / "scaling.md").write_text("\n".join(lines) + "\n")

    fig, ax = plt.subplots(figsize=(6, 4))
    for threads in sorted({r["threads"] for r in rows}):
        pts = sorted((r["particles"], r["particle_steps_per_s"]) for r in rows if r["threads"] == threads)
        ax.plot([p for p, _ in pts], [v / 1e6 for _, v in pts], "o-", label=f"celldem, {threads} thread(s)")
    for name, value in sorted(medians.items()):
        if name.startswith("lammps"):
            ax.axhline(value / 1e6, ls="--", color="grey")
            ax.annotate(name.replace("lammps-np", "LAMMPS, ranks "), (bench["particles"], value / 1e6),
                        textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel("particles")
    ax.set_ylabel("throughput [million particle-steps/s]")
    ax.set_title("Shear-phase throughput (TTC, mu = 0.5)")
    ax.grid(True, which="both", alpha=0.3)
    if rows:
        ax.legend()
    fig.tight_layout()
    fig.savefig(folder / "scaling.png", dpi=120)
    print(f"wrote {folder / 'scaling.md'} and {folder / 'scaling.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
