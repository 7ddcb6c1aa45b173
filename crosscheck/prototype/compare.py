#!/usr/bin/python3
"""Max relative difference between two series CSVs, per column."""
import sys, numpy as np
A = np.genfromtxt(sys.argv[1], delimiter=",", names=True)
B = np.genfromtxt(sys.argv[2], delimiter=",", names=True)
n = min(len(A), len(B))
for c in A.dtype.names[2:]:
    a, b = A[c][:n], B[c][:n]
    d = np.abs(a - b); scale = np.maximum(np.abs(a).max(), 1e-300)
    i = int(np.argmax(d))
    print("%-10s max|diff| %.3e (rel to max %.3e) first step with rel diff>1e-6: %s" %
          (c, d.max(), d.max() / scale,
           A["step"][:n][np.argmax(d / scale > 1e-6)] if (d / scale > 1e-6).any() else "none"))
