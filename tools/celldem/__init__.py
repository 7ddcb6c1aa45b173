"""celldem's Python tools: everything the entry scripts in tools/ and crosscheck/ share, and a small public API
for one's own scripts (api: open a run or an ensemble, build, check and run a deck; docs/python.md).

Modules, from the bottom up:
  binary      the celldem binary: `celldem plan DECK --json`, `celldem summarize SERIES` (summary.json's
              per-test quantities for a series without one, such as LAMMPS's or LIGGGHTS's), check, run
  files       the files of a run directory: summary.json, <stage>/series.csv (columns by its header),
              series.columns.json, progress.json's deck
  api         the public API (re-exported here): open_run, open_ensemble, Deck, check_deck, run_deck; the one run type;
              its errors: DeckError, RunFailed, RunError and FileFormatError (a file named, and what is wrong in it)
  results     the tools' view of an api.Run or api.Ensemble: its series as dicts of arrays (RunArrays, EnsembleArrays)
  metrics     curve helpers on series columns (interpolation, binned differences, maxima)
  decks       decks as data: load, edit, write with a generic JSON layout
  stats       t-test verdicts over the seeds of an ensemble (the statistics of ensemble.json, for curve measures)
  scenes      what a run holds: the paper's deck, constant-b (failure-surface) tests
  probes      a test's probes as celldem writes them, their envelopes in the solver's probe planes
  crosscheck  crosscheck/run_crosscheck.py (raises CrosscheckError; the script maps it to exit 1)
Sub-packages:
  reports      tools/report.py, tools/figures.py, tools/failure_surface.py (and the tables and plotting they share)
  study        tools/study.py and tools/sufficiency.py
  performance  tools/plot_bench.py and tools/roofline.py

What celldem computes (steps, strain per step, masses, the critical time step, the inertial number of a deck;
the peak, its plateau and the end values of a test) is read from `celldem plan --json` and summary.json,
never derived again here: a series from another code is summarized by `celldem summarize`.

How the package is found: the entry scripts live in tools/, beside it, and Python puts a script's own folder
first on sys.path, so `/usr/bin/python3 tools/report.py RUN_DIR` imports it with no set-up; other scripts and
the tests put tools/ on PYTHONPATH (ctest does: tests/CMakeLists.txt).
"""

from .api import (Deck, DeckError, Ensemble, FileFormatError, Run, RunError, RunFailed, Stage,  # noqa: E402
                  check_deck, open_ensemble, open_run, run_deck)

__all__ = ["Deck", "DeckError", "Ensemble", "FileFormatError", "Run", "RunError", "RunFailed", "Stage", "check_deck",
           "open_ensemble", "open_run", "run_deck"]
