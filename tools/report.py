#!/usr/bin/python3
"""Writes RUN_DIR/report.md: the run's results beside the paper's, its settings and timings, and its figures.

Usage: /usr/bin/python3 tools/report.py RUN_DIR [--refresh-figures]
The figures are (re)drawn into RUN_DIR/figures when any is missing, or always with --refresh-figures.
The report is tools/celldem/report.py.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from celldem import report, results  # noqa: E402


def main(argv=None):
    parser = results.run_dir_parser(__doc__)
    parser.add_argument("--refresh-figures", action="store_true", help="redraw the figures even if present")
    args = parser.parse_args(argv)
    run = results.load_run_or_report(args.run_dir, "report.py")
    if run is None:
        return 2
    print(f"wrote {report.write_report(run, args.refresh_figures)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
