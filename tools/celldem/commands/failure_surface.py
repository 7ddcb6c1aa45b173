"""The failure surface of a constant-b run (inputs/failure_surface.json): peak friction angle against b and
the peak states in the pi-plane, with Mohr-Coulomb, Matsuoka-Nakai and Lade-Duncan fitted.

Usage: /usr/bin/python3 tools/failure_surface.py RUN_DIR [--with PAPER_RUN_DIR]

Reads only summary.json (celldem computes every peak there: `peak_state` holds the principal stresses at
the row of the largest s11/s33). Writes RUN_DIR/figures/failure_surface_phi_b.png,
RUN_DIR/figures/failure_surface_pi_plane.png and RUN_DIR/failure_surface.md (the table and the fits). Tests whose control failed or that reached no peak
(summary.json "controlled" / "peak_reached" false) are kept out of the fits, with the count and the reason
printed; with fewer tests left than a criterion's constants + 1 there is no fit and the exit status is 1.
The fits are described in tools/celldem/reports/failure_surface.py.
"""

import argparse
import sys

from celldem import results
from celldem.reports import failure_surface


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("run_dir")
    ap.add_argument("--with", dest="paper", help="a paper run (TTC and PSC peaks overlaid)")
    args = ap.parse_args(argv)
    try:
        summary = results.load_summary(args.run_dir)
        excluded = failure_surface.left_out(summary)
        if excluded:
            print(f"failure_surface: {failure_surface.left_out_text(excluded)}", file=sys.stderr)
        points = failure_surface.peaks(summary)
        extra = failure_surface.peaks(results.load_summary(args.paper)) if args.paper else []
        md, phi_png, pi_png, text = failure_surface.write(args.run_dir, points, extra, excluded)
    except (results.RunError, ValueError) as err:
        sys.exit(f"failure_surface: {err}")
    print(text)
    print(f"wrote {md}, {phi_png}, {pi_png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
