"""Each seed's 1x and 8x tests judged by the three-rate ladder (rungs 0.5, 0.25 of the test's rate, two twins): the
distance from I -> 0 with its one-sided 95 % bounds (the code's propagation, tests/run/test_verify_rate.py's
independent NumPy implementation), against the pooled law's distance at that rate (analyse.py)."""
import json, sys, os
import numpy as np
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "run"))
import analyse as a
from test_verify_rate import fit, simulated_bounds

law = json.load(open(os.path.join(a.HERE, "ladder_fit.json")))
rows = []
for q, floor in a.FLOORS.items():
    Cl = law["quantities"][q]["rate"]["C"]; pl = law["quantities"][q]["rate"]["order"]
    for s in (1, 2):
        for top in (1.0, 8.0):
            rungs = [top, top / 2, top / 4]
            vals = [a.values(s, f)[q] for f in rungs]
            if top == 1.0:
                tw = [vals[0]] + [a.values(s, f)[q] for f in (1.001, 1.002)]
            else:
                tw = None
            q0, c, p = fit([1.0, 0.5, 0.25], vals)
            law_d = Cl * top ** pl / floor
            if tw:
                sd = float(np.std(tw, ddof=1))
                lo, hi = simulated_bounds([1.0, 0.5, 0.25], vals, sd, 2, 0.05, draws=500)
                inside = lo / floor <= law_d <= hi / floor
                rows.append((q, s, top, c / floor, lo / floor, hi / floor, p, law_d, inside))
                print(f"{q:20s} seed {s} {top:g}x: ladder {c / floor:+.2f} [{lo / floor:+.2f}, {hi / floor:+.2f}] floors, order {p:.2f}; "
                      f"law {law_d:+.2f}: {'inside' if inside else 'OUTSIDE'}")
            else:
                print(f"{q:20s} seed {s} {top:g}x: ladder {c / floor:+.2f} floors, order {p:.2f}; law {law_d:+.2f}")
json.dump(rows, open(os.path.join(a.HERE, "ladder_check.json"), "w"), indent=1)
