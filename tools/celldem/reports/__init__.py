"""Reports and figures of runs and seed ensembles (tools/report.py, tools/figures.py, tools/failure_surface.py).

  tables           Markdown tables and the formatting of numbers in them
  plotting         matplotlib without a display, thinning long curves, axis units from series.columns.json
  force_chains     the strong force chains at each test's peak (peak_contacts.csv)
  figures          the figures of a run or an ensemble, and which of them are due
  failure_surface  the failure surface of constant-b tests: table and figures
  report           a single run's report.md, and the sections an ensemble's report shares
  ensemble_report  an ensemble's report.md (the statistics of ensemble.json, the paper's findings as verdicts)
  writer           write_report: report.md for a run or an ensemble, whichever the folder holds
"""
