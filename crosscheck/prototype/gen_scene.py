#!/usr/bin/python3
"""Generate a SPARSE periodic sphere packing as a LAMMPS/LIGGGHTS data file.

Like the paper (sec. 4): spheres on the points of a cubic grid, diameters drawn
at random from NSIZES discrete sizes in [DMIN, DMAX]; one atom TYPE per distinct
diameter (type k <-> k-th size), so per-type settings (fix viscous / langevin
scale) can encode the mass-dependent body damping.  The sparse sample is then
compressed to the target stress by in.prep.lmp (LAMMPS), which write_data's the
dense sample used by the test templates.

Data-file layout (verified with both codes):
  atom_style sphere (LAMMPS) / granular (LIGGGHTS) Atoms line:
      id type diameter density x y z          (SI: m, kg/m^3)
  Velocities line (both):  id vx vy vz wx wy wz (m/s, rad/s)

usage: gen_scene.py OUT.data [--n 8] [--seed 1] [--nsizes 16] [--spin 0]
  --n      grid points per edge (N = n^3 spheres, default 8 -> 512)
  --spin   if >0, give every sphere random v (|v|<spin m/s) and w (|w|<spin/r)
           -- only used to check the Velocities column layout.
"""
import argparse
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("out")
ap.add_argument("--n", type=int, default=8)
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--nsizes", type=int, default=16)
ap.add_argument("--dmin", type=float, default=3.0e-3)
ap.add_argument("--dmax", type=float, default=4.5e-3)
ap.add_argument("--rho", type=float, default=2650.0)
ap.add_argument("--gap", type=float, default=1.15, help="grid spacing / dmax")
ap.add_argument("--spin", type=float, default=0.0)
a = ap.parse_args()

rng = np.random.default_rng(a.seed)
sizes = np.linspace(a.dmin, a.dmax, a.nsizes)
n = a.n
N = n ** 3
h = a.gap * a.dmax
L = n * h
g = (np.arange(n) + 0.5) * h
X, Y, Z = np.meshgrid(g, g, g, indexing="ij")
pos = np.c_[X.ravel(), Y.ravel(), Z.ravel()]
pos += rng.uniform(-0.05, 0.05, pos.shape) * h  # break symmetry a little
typ = rng.integers(0, a.nsizes, N)               # 0-based size index
d = sizes[typ]

with open(a.out, "w") as f:
    f.write("celldem prototype scene: %d spheres, %d sizes, sparse grid\n\n" % (N, a.nsizes))
    f.write("%d atoms\n%d atom types\n\n" % (N, a.nsizes))
    f.write("0 %.17g xlo xhi\n0 %.17g ylo yhi\n0 %.17g zlo zhi\n\n" % (L, L, L))
    f.write("Atoms # sphere\n\n")
    for i in range(N):
        f.write("%d %d %.17g %.17g %.17g %.17g %.17g\n"
                % (i + 1, typ[i] + 1, d[i], a.rho, *pos[i]))
    f.write("\nVelocities\n\n")
    v = np.zeros((N, 3)); w = np.zeros((N, 3))
    if a.spin > 0:
        v = rng.uniform(-a.spin, a.spin, (N, 3))
        w = rng.uniform(-a.spin, a.spin, (N, 3)) / (0.5 * d[:, None])
    for i in range(N):
        f.write("%d %.17g %.17g %.17g %.17g %.17g %.17g\n" % (i + 1, *v[i], *w[i]))
print("wrote %s: N=%d L=%.6g m, solid fraction %.3f" %
      (a.out, N, L, np.sum(np.pi / 6 * d ** 3) / L ** 3))
