"""RUN_DIR/report.md for whatever RUN_DIR holds: a single run gets report.py's report, an ensemble folder
(ensemble.json, seed-<k>/) ensemble_report.py's. The one place that chooses between them, so that
ensemble_report, which builds on report's sections, is imported by report's callers and never by report."""

import os

from .. import scenes
from ..results import EnsembleArrays
from . import ensemble_report, figures, report


def write_report(run, refresh_figures=False, paper=None):
    """Draws the figures when any is missing or older than the run's files (or always with refresh_figures), writes
    report.md; returns its path.
    paper None: the paper's comparison when the run is the paper's deck (scenes.is_paper); True forces it."""
    paper = scenes.is_paper(run) if paper is None else paper
    planned = figures.plan(run, paper)
    fig_dir = os.path.join(run.directory, "figures")
    if refresh_figures or figures.stale(fig_dir, planned, run.directory):
        figures.write_figures(run, fig_dir, paper)
    build = ensemble_report.build_report if isinstance(run, EnsembleArrays) else report.build_report
    text = build(run, paper, planned)
    path = os.path.join(run.directory, "report.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path
