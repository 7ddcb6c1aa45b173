#!/usr/bin/python3
"""Independent contact count and normal-force contact stress of a data file
(valid where tangential forces are zero, e.g. the frictionless prepared sample):
sigma_ab = (1/V) sum_c f_a l_b, f = KN*overlap*n, compression positive."""
import sys, numpy as np
fn = sys.argv[1]; kn = float(sys.argv[2]) if len(sys.argv) > 2 else 1e6
lo = np.zeros(3); hi = np.zeros(3); rows = []; sec = None
for line in open(fn):
    s = line.split("#")[0].strip()
    if not s: continue
    f = s.split()
    if len(f) == 4 and f[2][1:] in ("lo", "") and f[3].endswith("hi"):
        k = "xyz".index(f[2][0]); lo[k] = float(f[0]); hi[k] = float(f[1]); continue
    if s[0].isalpha(): sec = s; continue
    if sec == "Atoms": rows.append([float(v) for v in f[:7]])
A = np.array(rows); L = hi - lo; x = A[:, 4:7]; r = A[:, 2] / 2
n = len(A); S = np.zeros((3, 3)); nc = 0
for i in range(n):
    d = x[i] - x[i + 1:]; d -= L * np.round(d / L)
    dist = np.linalg.norm(d, axis=1); ov = r[i] + r[i + 1:] - dist
    m = ov > 0; nc += m.sum()
    fvec = (kn * ov[m] / dist[m])[:, None] * d[m]
    S += fvec.T @ d[m]
S /= np.prod(L)
print("contacts", nc, "s11 s22 s33 %.10g %.10g %.10g" % (S[0, 0], S[1, 1], S[2, 2]),
      "solid fraction %.4f" % (np.sum(4 / 3 * np.pi * r ** 3) / np.prod(L)))
