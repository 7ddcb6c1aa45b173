"""Writes RUN_DIR/report.md: the run's tests, preparation, force chains and figures, and for the paper's deck its
results beside the paper's; for an ensemble folder (ensemble.json, seed-<k>/) the same over the seeds, with bands
and statistical verdicts.

Usage: /usr/bin/python3 tools/report.py RUN_DIR [--refresh-figures] [--paper | --no-paper]
The figures are (re)drawn into RUN_DIR/figures when any is missing or older than a file of the run (a test that went
on, an ensemble that gained seeds), or always with --refresh-figures.
The paper's comparison is made when the run is the paper's deck (its scene, tests named ttc/psc); --paper forces
it, --no-paper leaves it out. The report is tools/celldem/reports/report.py (ensembles: ensemble_report.py).
"""

import sys

from celldem import results
from celldem.reports import writer


def main(argv=None):
    parser = results.run_dir_parser(__doc__)
    parser.add_argument("--refresh-figures", action="store_true", help="redraw the figures even if present")
    paper = parser.add_mutually_exclusive_group()
    paper.add_argument("--paper", action="store_true", default=None, help="compare with the paper whatever the deck")
    paper.add_argument("--no-paper", dest="paper", action="store_false", help="no comparison with the paper")
    args = parser.parse_args(argv)
    run = results.load_run_or_report(args.run_dir, "report.py")
    if run is None:
        return 2
    print(f"wrote {writer.write_report(run, args.refresh_figures, args.paper)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
