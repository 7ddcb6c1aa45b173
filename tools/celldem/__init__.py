"""celldem's Python tools: everything the entry scripts in tools/ and crosscheck/ share.

Modules, from the bottom up:
  tables    Markdown tables and the formatting of numbers in them
  results   run directories: summary.json, <stage>/series.csv (columns by its header), series.columns.json
  metrics   curve helpers on series columns (interpolation, binned differences, maxima)
  binary    the celldem binary: `celldem plan DECK --json`, `celldem summarize SERIES` (summary.json's
            per-test quantities for a series without one, such as LAMMPS's or LIGGGHTS's)
  decks     decks as data: load, edit, write with a generic JSON layout
  plotting  matplotlib without a display, thinning long curves, axis units from series.columns.json
  stats     t-test verdicts over the seeds of an ensemble (the statistics of ensemble.json, for curve measures)
  scenes    what a run holds: the paper's deck, constant-b (failure-surface) tests
  force_chains                    the strong force chains at each test's peak (peak_contacts.csv)
  figures, report, ensemble_report  tools/figures.py and tools/report.py (runs and seed ensembles)
  study_scene, study_runs, study_analysis, study_report   tools/study.py
  crosscheck                      crosscheck/run_crosscheck.py
  bench, failure_surface          tools/plot_bench.py and tools/failure_surface.py

What celldem computes (steps, strain per step, masses, the critical time step, the inertial number of a deck;
the peak, its plateau and the end values of a test) is read from `celldem plan --json` and summary.json,
never derived again here: a series from another code is summarized by `celldem summarize`.
"""
