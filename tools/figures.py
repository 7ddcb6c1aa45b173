#!/usr/bin/python3
"""Plots a celldem run the way the paper plots it (Figures 2-12), every test overlaid on the same axes.

Usage: /usr/bin/python3 tools/figures.py RUN_DIR [--out FIGDIR]
Writes one PNG per figure, two extra diagnostic figures and overview.png to FIGDIR (default RUN_DIR/figures).
The drawing is tools/celldem/figures.py.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from celldem import figures, results  # noqa: E402


def main(argv=None):
    parser = results.run_dir_parser(__doc__)
    parser.add_argument("--out", help="folder for the PNGs (default RUN_DIR/figures)")
    args = parser.parse_args(argv)
    run = results.load_run_or_report(args.run_dir, "figures.py")
    if run is None:
        return 2
    if not run.test_names:
        print(f"figures.py: warning: no <test>/series.csv in {args.run_dir}; figures will be empty", file=sys.stderr)
    written = figures.write_figures(run, args.out or os.path.join(args.run_dir, "figures"))
    print(f"wrote {len(written)} figures to {os.path.dirname(written[0])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
