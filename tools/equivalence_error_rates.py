#!/usr/bin/python3
"""The equivalence gate's error rates by simulation (tools/celldem/performance/equivalence_sim.py: synthetic paired
ensembles judged by the gate's own code), as docs/performance.md quotes them: a Markdown table on stdout, with each
rate's 95 % interval (scipy.stats.binomtest), and the figure of the pass rate against the true shift.

Usage: /usr/bin/python3 tools/equivalence_error_rates.py [--reps 4000] [--seeds 30] [--reference-seeds 20]
                                                          [--figure docs/figures/equivalence_error_rates.png]
About 1.5 ms of CPU a draw: the default table and figure take about 3 minutes of one core.
"""

import argparse
import os
import sys

from celldem.performance import equivalence_sim as sim

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rate_text(result, rate):
    count, reps = result["counts"][rate], result["reps"]
    lo, hi = sim.interval(count, reps)
    return f"{count / reps:.3f} [{lo:.3f}, {hi:.3f}]"


def main(argv=None):
    parser = argparse.ArgumentParser(description="The equivalence gate's error rates by simulation.")
    parser.add_argument("--reps", type=int, default=4000, help="draws per row (default 4000)")
    parser.add_argument("--seeds", type=int, default=30, help="judged seeds (default 30, the gate's)")
    parser.add_argument("--reference-seeds", type=int, default=20, help="reference seeds (default 20, the gate's)")
    parser.add_argument("--figure", default=os.path.join(ROOT, "docs", "figures", "equivalence_error_rates.png"),
                        help="where to draw the pass rate against the shift ('' for none)")
    args = parser.parse_args(argv)
    if args.reps < 100 or args.seeds < 4 or args.reference_seeds < 3:
        print("equivalence_error_rates.py: error: --reps >= 100, --seeds >= 4, --reference-seeds >= 3",
              file=sys.stderr)
        return 2
    n, R, reps = args.seeds, args.reference_seeds, args.reps
    rows = [
        ("shift = the margin (0.5 reference floors)", dict(shift=1.0, shift_mode="margin", rho=0.5), "pass"),
        ("shift = the margin, tight pairs", dict(shift=1.0, shift_mode="margin", rho=0.95), "pass"),
        ("shift = 0.5 true floors", dict(shift=0.5, rho=0.5), "pass"),
        ("shift = 0.5 true floors, tight pairs", dict(shift=0.5, rho=0.95), "pass"),
        ("old rule: shift = 0.5 true floors, tight pairs", dict(shift=0.5, rho=0.95, legacy=True), "pass"),
        ("old rule, 8 seeds: shift = 0.5 true floors, tight pairs",
         dict(shift=0.5, rho=0.99, legacy=True, n=8, reference_n=8), "pass"),
        ("no shift, pairs ρ = 0 (power)", dict(rho=0.0), "gate"),
        ("no shift, ρ = 0.5 (power)", dict(rho=0.5), "gate"),
        ("no shift, ρ = 0.9 (power)", dict(rho=0.9), "gate"),
        ("no shift, ρ = 0.5: spread check trips", dict(rho=0.5), "spread"),
        ("no shift, ρ = 0.5: called different", dict(rho=0.5), "different"),
        ("2× chaos, ρ = 0.5: spread check trips", dict(rho=0.5, chaos=2.0), "spread"),
        ("2× chaos, ρ = 0.5: gate passes", dict(rho=0.5, chaos=2.0), "gate"),
        ("2× chaos, ρ = 0.9: spread check trips", dict(rho=0.9, chaos=2.0), "spread"),
        ("2× chaos, ρ = 0.9: gate passes", dict(rho=0.9, chaos=2.0), "gate"),
    ]
    print(f"{n} judged seeds, {R} reference seeds, margin 0.5 floors, α = 0.05, {reps} draws a row "
          "(95 % intervals, binomtest).\n")
    print("| case | rate | value [95 % interval] |\n|---|---|---|")
    for k, (label, options, rate) in enumerate(rows):
        options = {"n": n, "reference_n": R, **options}
        r = sim.simulate(reps=reps, seed=100 + k, **options)
        print(f"| {label} (n {options['n']}, R {options['reference_n']}) | {rate} | {rate_text(r, rate)} |",
              flush=True)
    if args.figure:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        shifts = [0.0, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5]
        fig, ax = plt.subplots(figsize=(6.4, 4.0))
        for rho, style in ((0.5, "o-"), (0.9, "s-")):
            rates = [sim.simulate(n=n, reference_n=R, rho=rho, shift=s, shift_mode="margin", reps=reps // 2,
                                  seed=200 + i)["rates"]["pass"] for i, s in enumerate(shifts)]
            ax.plot(shifts, rates, style, label=f"ρ = {rho} (OLD–NEW correlation on a seed)")
        ax.axhline(0.05, color="grey", lw=0.8, ls="--")
        ax.axvline(1.0, color="grey", lw=0.8, ls=":")
        ax.set_xlabel("true shift of NEW's mean / the margin")
        ax.set_ylabel("TOST passes (equivalent)")
        ax.set_title(f"Equivalence gate, {n} seeds, margin 0.5 floors of {R} reference seeds")
        ax.legend()
        fig.tight_layout()
        fig.savefig(args.figure, dpi=110)
        print(f"\nfigure: {args.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
