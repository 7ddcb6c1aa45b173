"""Plots a celldem run or seed ensemble: a figure per test, the preparation, the tests overlaid the way the paper
plots them (Figures 2-12, for the paper's deck or two tests or more), the force chains at the peaks.

Usage: /usr/bin/python3 tools/figures.py RUN_DIR [--out FIGDIR] [--paper]
Writes one PNG per figure to FIGDIR (default RUN_DIR/figures); what the run holds no data for is not drawn.
The drawing is tools/celldem/reports/figures.py.
"""

import os
import sys

from celldem import results, scenes
from celldem.reports import figures


def main(argv=None):
    parser = results.run_dir_parser(__doc__)
    parser.add_argument("--out", help="folder for the PNGs (default RUN_DIR/figures)")
    parser.add_argument("--paper", action="store_true", help="number and caption the figures as the paper's")
    args = parser.parse_args(argv)
    run = results.load_run_or_report(args.run_dir, "figures.py")
    if run is None:
        return 2
    out = args.out or os.path.join(args.run_dir, "figures")
    written = figures.write_figures(run, out, args.paper or scenes.is_paper(run))
    print(f"wrote {len(written)} figures to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
