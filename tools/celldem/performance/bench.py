"""The scaling table and plot of `celldem bench --scaling` (tools/plot_bench.py): DIR/bench.json ->
DIR/scaling.md and DIR/scaling.png."""

from pathlib import Path

from ..files import load_json
from ..reports import plotting
from ..reports.tables import md_table


def _mega(value):
    return f"{value / 1e6:.3g} M"


def _sample(row):
    """Which sample a scaling row timed: its source (an extra state's path or "copies K"), or for a bench.json
    written before rows named it, its size and copy count."""
    return row.get("source", (row["particles"], row.get("copies")))


def parallel_efficiency(rows):
    """Per scaling row, (speed-up, parallel efficiency) over the first one-thread row of the same sample:
    rate / rate_1 and rate / (threads x rate_1); (None, None) where the sample has no one-thread row."""
    one = {}
    for r in rows:
        if r["threads"] == 1:
            one.setdefault(_sample(r), r["particle_steps_per_s"])
    out = []
    for r in rows:
        base = one.get(_sample(r))
        speedup = r["particle_steps_per_s"] / base if base else None
        out.append((speedup, speedup / r["threads"] if speedup is not None else None))
    return out


def scaling_markdown(bench):
    rows = bench.get("scaling", [])
    efficiency = parallel_efficiency(rows)
    lines = [md_table(("particles", "threads", "steps", "particle-steps/s", "speed-up", "parallel efficiency",
                       "bytes/particle", "particles / pairs / model", "peak RSS [MiB]"),
                      [(r["particles"], r["threads"], r["steps"], f"{r['particle_steps_per_s']:.3g}",
                        f"{e[0]:.2f}" if e[0] is not None else "", f"{e[1]:.2f}" if e[1] is not None else "",
                        f"{r['bytes_per_particle']:.0f}",
                        " / ".join(f"{r['bytes_per_particle_breakdown'][k]:.0f}" for k in ("particles", "pairs", "model"))
                        if "bytes_per_particle_breakdown" in r else "",
                        r.get("max_rss_mib", "")) for r, e in zip(rows, efficiency)], align="rrrrrrrrr")]
    medians = bench.get("median_particle_steps_per_s", {})
    lines += ["", md_table(("run", "median particle-steps/s"), [(k, f"{v:.3g}") for k, v in sorted(medians.items())],
                           align="lr")]
    if "ratio" in bench:
        lines += ["", f"ratio (celldem, most threads / LAMMPS, most ranks): {bench['ratio']:.2f}"]
    if "lammps_settings" in bench:
        settings = bench["lammps_settings"]
        lines += ["", "LAMMPS settings (the bench's copy of the translated script): " +
                  "; ".join(f"{k} {v}" for k, v in settings.items())]
    if "bytes_per_particle_breakdown" in bench:
        parts = bench["bytes_per_particle_breakdown"]
        lines += ["", f"memory: {bench['bytes_per_particle']:.0f} bytes per particle (particles {parts['particles']:.0f}, "
                      f"pairs {parts['pairs']:.0f}, model {parts['model']:.0f})"]
    if bench.get("step_seconds") and bench.get("row_seconds"):
        lines += ["", f"one series row costs {bench['row_seconds']:.3g} s = "
                      f"{bench['row_seconds'] / bench['step_seconds']:.2f} steps"]
    if "contention" in bench:
        lines += ["", md_table(("beside a busy process", "particle-steps/s"),
                               [(k, _mega(v["particle_steps_per_s"])) for k, v in bench["contention"].items()],
                               align="lr")]
    if "laws" in bench:
        lines += ["", md_table(("contact law", "particle-steps/s", "cost vs linear"),
                               [(k, _mega(v["particle_steps_per_s"]), f"{v['cost_relative_to_linear']:.2f}")
                                for k, v in bench["laws"].items()], align="lrr")]
    if "whole_process" in bench:
        wp = bench["whole_process"]
        lines += ["", f"whole processes, {wp['steps']} steps from the state (wall time, medians):", "",
                  md_table(("celldem threads", "LAMMPS ranks", "celldem run [s]", "lmp [s]", "LAMMPS / celldem"),
                           [(p["threads"], p["ranks"], f"{p['celldem_seconds']:.2f}", f"{p['lammps_seconds']:.2f}",
                             f"{p['ratio']:.2f}") for p in wp.get("pairs", [])], align="rrrrr")]
    return "\n".join(lines) + "\n"


def scaling_plot(bench, path):
    rows = bench.get("scaling", [])
    medians = bench.get("median_particle_steps_per_s", {})
    fig, ax = plotting.pyplot().subplots(figsize=(6, 4))
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
    return plotting.save(fig, path)


def write_scaling(folder):
    """Reads folder/bench.json, writes scaling.md and scaling.png beside it; returns their paths."""
    folder = Path(folder)
    bench = load_json(folder / "bench.json")
    (folder / "scaling.md").write_text(scaling_markdown(bench))
    return folder / "scaling.md", scaling_plot(bench, folder / "scaling.png")
