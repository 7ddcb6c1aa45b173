"""The speed–accuracy study (tools/study.py) and the model-sufficiency check (tools/sufficiency.py).

  scene        the study's reduced scene of the paper's TTC and PSC, the compared quantities and their labels
  runs         its plan of runs, their decks, running them (the celldem binary) and their outcomes
  analysis     the noise floor, the errors, the Pareto front, the presets, the stability and servo measures
  report       study.md, study.json and the charts
  sufficiency  the model switches (one sub-model replaced at a time) and their verdicts
"""
