#!/usr/bin/env python3
"""The energy budget's closure error against the time step and the loading rate (docs/energy.md), on
small_run.json's sample prepared once, every run from that state, `dynamic` so that nothing stops a boiling packing.

    tools/energy_sweep.py dt    --celldem build/celldem --out /tmp/sweep [--figure docs/figures/energy_dt_sweep.png]
    tools/energy_sweep.py order --celldem build/celldem --out /tmp/order [--variants base,no_damping,...]
    tools/energy_sweep.py rate  --celldem build/celldem --out /tmp/rate  [--figure docs/figures/energy_dt_rate.png]
    tools/energy_sweep.py figure --celldem build/celldem --out /tmp/rate --order-csv /tmp/order/energy_order.csv \
        --figure docs/figures/energy_dt_rate.png [--compare DIR]   (the rate mode's figure from its CSVs)

`dt`: the TTC at fractions of the stability limit t_c up to 0.92, at one strain rate (the strain increment per
step scaled with the step), with the deck's damping and none: the worst |closure| / boundary work.
`order`: the closure's order in dt below 0.5 t_c, one physics term switched off at a time (VARIANTS); each
variant's end-of-test closure / work fitted as C dt^p on log-log (scipy linregress, p with its 95 % interval).
`rate`: the closure against the strain rate (and the inertial number) at fixed dt / t_c, and against dt at a fixed
strain increment per step, beside the `order` runs at a fixed rate; with --figure, the two-panel chart.
"""
import argparse
import csv
import json
import os
import subprocess

import numpy as np
from scipy import stats

HERE = os.path.dirname(os.path.abspath(__file__))
DECK = os.path.join(HERE, "..", "tests", "run", "small_run.json")
FRACTIONS = (0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 0.92)
ORDER_FRACTIONS = (0.05, 0.1, 0.2, 0.3, 0.5)
RATE_FACTORS = (0.25, 0.5, 1.0, 2.0, 4.0)
RATE_DT = 0.3  # dt / t_c of the rate sweep


def run(celldem, deck, out):
    path = out + ".json"
    with open(path, "w") as f:
        json.dump(deck, f)
    subprocess.run([celldem, "run", path, "--out", out, "--force", "--quiet", "--threads", "1", "--fixed-threads"],
                   check=True)
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def stability_limit(celldem, deck_path):
    plan = json.loads(subprocess.run([celldem, "plan", deck_path, "--json"], check=True, capture_output=True,
                                     text=True).stdout)
    return plan["critical_time_step"]


def prepare(celldem, out):
    """small_run.json's sample, prepared once; returns (base deck, prepared state, t_c, the deck's rate [1/s])."""
    with open(DECK) as f:
        base = json.load(f)
    base["energy_budget"] = True
    state = os.path.join(out, "prep", "prepared.state")
    if not os.path.exists(state):
        run(celldem, dict(base, tests=[]), os.path.join(out, "prep"))
    with open(os.path.join(out, "prep.json"), "w") as f:
        json.dump(dict(base, tests=[]), f)
    t_c = stability_limit(celldem, os.path.join(out, "prep.json"))
    rate = base["tests"][0]["axes"]["x1"]["strain_increment"] / base["time_step"]
    return base, state, t_c, rate


# One physics term off at a time (order): each edits the deck and the TTC's axes.
def _strain_driven(deck, ttc):
    ttc["axes"]["x2"] = {"strain_increment": 0.0}
    ttc["axes"]["x3"] = {"strain_increment": 0.0}


def _isotropic(deck, ttc):
    inc = ttc["axes"]["x1"]["strain_increment"]
    ttc["axes"] = {k: {"strain_increment": inc} for k in ("x1", "x2", "x3")}


def _simple_shear(deck, ttc):
    inc = ttc["axes"]["x1"]["strain_increment"]
    ttc["axes"] = {"x1": {"strain_increment": 0.0}, "x2": {"stress": 1e5}, "x3": {"strain_increment": 0.0},
                   "x12": {"strain_increment": inc}}
    ttc["end"] = {"axis": "x12", "strain": 2 * ttc["end"]["strain"]}


VARIANTS = {
    "base": lambda d, t: None,
    "no_damping": lambda d, t: d.update(damping={"translational": 0.0, "rotational": 0.0}),
    "strain_driven": _strain_driven,
    "no_sliding": lambda d, t: t.update(friction=1000.0),
    "frictionless": lambda d, t: t.update(friction=0.0),
    "project": lambda d, t: d["contact"].update(tangential_rotation="project"),
    "isotropic": _isotropic,
    "simple_shear": _simple_shear,
}


def ttc_deck(base, state, dt, increment, strain, damping="deck", variant="base"):
    deck = json.loads(json.dumps(base))
    deck.pop("prepare")
    deck["initial_state"] = state
    if damping == "none":
        deck["damping"] = {"translational": 0.0, "rotational": 0.0}
    deck["time_step"] = dt
    deck["control_failure"] = "warn"  # (a servo lagging at no friction is still a budget to close)
    ttc = deck["tests"][0]
    ttc["axes"]["x1"]["strain_increment"] = increment
    ttc["end"]["strain"] = strain
    ttc["dynamic"] = True
    VARIANTS[variant](deck, ttc)
    ttc["output_interval"] = max(1, int(round(250 * base["time_step"] / dt)))
    deck["tests"] = [ttc]
    return deck


def test_row(summary, **keys):
    t = summary["tests"]["ttc"]
    e = t["energy"]
    return dict(keys, worst_closure_relative=e["worst_closure_relative"], closure_relative=e["closure_relative"],
                damping_share=e["damping_share"], boundary_work=e["boundary_work"], friction=e["friction"],
                inertial_number=t.get("inertial_number"), steps=t.get("steps"))


def write_csv(rows, path):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def fit_order(x, y):
    """log|y| = log C + p log x by least squares: (p, its 95 % half-width, r^2)."""
    fit = stats.linregress(np.log(x), np.log(np.abs(y)))
    half = stats.t.ppf(0.975, len(x) - 2) * fit.stderr
    return fit.slope, half, fit.rvalue ** 2


def sweep_dt(args):
    base, state, t_c, rate = prepare(args.celldem, args.out)
    rows = []
    for damping in ("deck", "none"):
        for frac in FRACTIONS:
            dt = frac * t_c
            s = run(args.celldem, ttc_deck(base, state, dt, rate * dt, args.strain, damping),
                    os.path.join(args.out, f"ttc_{damping}_{frac:g}"))
            rows.append(test_row(s, damping=damping, dt_over_tc=frac, dt=dt))
            print(rows[-1], flush=True)
    write_csv(rows, os.path.join(args.out, "energy_dt_sweep.csv"))
    if args.figure:
        plt = pyplot()
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


def sweep_order(args):
    base, state, t_c, rate = prepare(args.celldem, args.out)
    rows, fits = [], []
    for variant in args.variants.split(","):
        for frac in ORDER_FRACTIONS:
            dt = frac * t_c
            s = run(args.celldem, ttc_deck(base, state, dt, rate * dt, args.strain, variant=variant),
                    os.path.join(args.out, f"{variant}_{frac:g}"))
            rows.append(test_row(s, variant=variant, dt_over_tc=frac, dt=dt))
            print(rows[-1], flush=True)
        mine = [r for r in rows if r["variant"] == variant]
        p, half, r2 = fit_order([r["dt"] for r in mine], [r["closure_relative"] for r in mine])
        signs = "".join("+" if r["closure_relative"] > 0 else "-" for r in mine)
        fits.append({"variant": variant, "order": p, "order_95": half, "r2": r2, "signs": signs,
                     "closure_at_0.3": next(r["closure_relative"] for r in mine if r["dt_over_tc"] == 0.3)})
        print(f"{variant}: order {p:.3f} ± {half:.3f} (95 %), r² {r2:.4f}, signs {signs}", flush=True)
    write_csv(rows, os.path.join(args.out, "energy_order.csv"))
    write_csv(fits, os.path.join(args.out, "energy_order_fits.csv"))


def sweep_rate(args):
    base, state, t_c, rate = prepare(args.celldem, args.out)
    rows = []
    dt = RATE_DT * t_c
    for factor in RATE_FACTORS:  # fixed dt, the rate varied
        s = run(args.celldem, ttc_deck(base, state, dt, factor * rate * dt, args.strain),
                os.path.join(args.out, f"rate_{factor:g}"))
        rows.append(test_row(s, sweep="rate", dt_over_tc=RATE_DT, dt=dt, rate=factor * rate))
        print(rows[-1], flush=True)
    increment = rate * dt  # fixed strain increment per step, dt varied (the rate with it)
    for frac in ORDER_FRACTIONS:
        s = run(args.celldem, ttc_deck(base, state, frac * t_c, increment, args.strain),
                os.path.join(args.out, f"increment_{frac:g}"))
        rows.append(test_row(s, sweep="increment", dt_over_tc=frac, dt=frac * t_c, rate=increment / (frac * t_c)))
        print(rows[-1], flush=True)
    for sweep in ("rate", "increment"):
        mine = [r for r in rows if r["sweep"] == sweep]
        x = [r["rate"] if sweep == "rate" else r["dt"] for r in mine]
        p, half, r2 = fit_order(x, [r["closure_relative"] for r in mine])
        print(f"{sweep}: order {p:.3f} ± {half:.3f} (95 %), r² {r2:.4f}", flush=True)
    write_csv(rows, os.path.join(args.out, "energy_rate.csv"))
    if args.figure:
        draw_dt_rate(args, rows)


def figure_only(args):
    """The rate mode's figure from the CSVs already in --out (and --compare)."""
    with open(os.path.join(args.out, "energy_rate.csv")) as f:
        rows = [dict(r, **{k: float(r[k]) for k in ("dt_over_tc", "closure_relative", "inertial_number")})
                for r in csv.DictReader(f)]
    draw_dt_rate(args, rows)


def draw_dt_rate(args, rows):
    """Two panels: closure against dt / t_c (at the deck's rate, from --order-csv; and at a fixed strain
    increment per step), and against the inertial number at fixed dt; with --compare, another binary's runs
    dashed (the same sweeps run with it into that folder)."""
    plt = pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(10.0, 4.2))
    sets = [("", "-", args.order_csv, rows)]
    if args.compare:
        with open(os.path.join(args.compare, "energy_rate.csv")) as f:
            other = [dict(r, **{k: float(r[k]) for k in ("dt_over_tc", "closure_relative", "inertial_number")})
                     for r in csv.DictReader(f)]
        sets.append((f" ({args.compare_label})", "--", os.path.join(args.compare, "energy_order.csv"), other))
    for suffix, style, order_csv, rate_rows in sets:
        if order_csv and os.path.exists(order_csv):
            with open(order_csv) as f:
                order = list(csv.DictReader(f))
            drawn = (("base", "C0"), ("no_damping", "C1"), ("frictionless", "C2"))  # (frictionless: no change)
            for variant, color in drawn[:3 if style == "-" else 2]:
                pts = [(float(r["dt_over_tc"]), abs(float(r["closure_relative"]))) for r in order
                       if r["variant"] == variant]
                if pts:
                    x, y = np.array(pts).T
                    a.loglog(x, y, style, marker="o", color=color, ms=4,
                             label=f"{variant.replace('_', ' ')}, rate fixed{suffix}")
        inc = [(r["dt_over_tc"], abs(r["closure_relative"])) for r in rate_rows if r["sweep"] == "increment"]
        x, y = np.array(inc).T
        a.loglog(x, y, style, marker="D", ms=4, color="k", label=f"base, strain per step fixed{suffix}")
        pts = [(r["inertial_number"], abs(r["closure_relative"])) for r in rate_rows if r["sweep"] == "rate"]
        x, y = np.array(pts).T
        b.loglog(x, y, style, marker="o", ms=4, color="C0", label=f"base, dt = {RATE_DT:g} t_c{suffix}")
    for ax, slope, x0, y0 in ((a, 1, 0.05, 1.5e-5), (a, 2, 0.05, 2e-8), (b, 1, 2.2e-4, 1.5e-5)):
        xs = np.array([x0, 10 * x0 if ax is b else 0.5])
        ax.loglog(xs, y0 * (xs / x0) ** slope, ":", color="0.5", linewidth=1)
        ax.annotate(f"∝ x^{slope}", (xs[-1], y0 * (xs[-1] / x0) ** slope), fontsize=7, color="0.4")
    a.set_xlabel("time step / stability limit t_c")
    a.set_ylabel("|closure| / boundary work at the test's end")
    a.set_title("against the time step", fontsize=10)
    b.set_xlabel("inertial number I (strain rate 0.25 to 4 /s)")
    b.set_title("against the loading rate", fontsize=10)
    for ax in (a, b):
        ax.grid(True, which="both", linewidth=0.4, alpha=0.5)
        ax.legend(fontsize=6, loc="lower right")
    fig.suptitle("Energy closure error, 150 spheres, TTC to ε1 = 0.3 % (tools/energy_sweep.py)", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.figure, dpi=90)


def pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("dt", "order", "rate", "figure"), nargs="?", default="dt")
    ap.add_argument("--celldem", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--figure")
    ap.add_argument("--strain", type=float, default=0.003)
    ap.add_argument("--variants", default=",".join(VARIANTS))
    ap.add_argument("--order-csv", help="rate --figure: the order sweep's energy_order.csv for the dt panel")
    ap.add_argument("--compare", help="rate --figure: a folder with another binary's order and rate runs, dashed")
    ap.add_argument("--compare-label", default="the cap's slip at the mean force")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    {"dt": sweep_dt, "order": sweep_order, "rate": sweep_rate, "figure": figure_only}[args.mode](args)


if __name__ == "__main__":
    main()
