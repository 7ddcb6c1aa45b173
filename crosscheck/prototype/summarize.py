#!/usr/bin/python3
"""Summarize series CSVs: strain e1 (engineering, from lx), stresses, servo lag."""
import sys, numpy as np
for fn in sys.argv[1:]:
    D = np.genfromtxt(fn, delimiter=",", names=True)
    e1 = 1 - D["lx"] / D["lx"][0]; e2 = 1 - D["ly"] / D["ly"][0]; e3 = 1 - D["lz"] / D["lz"][0]
    n = len(D); h = n // 2
    lag2 = D["s22"][h:] - 1e5; lag3 = D["s33"][h:] - 1e5
    print("%-22s steps %6d e1 %.3e e2 %+.3e e3 %+.3e | s11 %.4g s22 %.4g s33 %.4g | 2nd half: "
          "lag22 mean %+.0f sd %.0f  lag33 mean %+.0f sd %.0f | nc %d ke %.2e"
          % (fn, D["step"][-1], e1[-1], e2[-1], e3[-1], D["s11"][-1], D["s22"][-1], D["s33"][-1],
             lag2.mean(), lag2.std(), lag3.mean(), lag3.std(), D["ncontacts"][-1], D["ke_trans"][-1] + D["ke_rot"][-1]))
