#!/usr/bin/python3
"""Extract per-atom drag coefficients from a 1-step LAMMPS/LIGGGHTS dump
(dump.MODE, two frames) and compare with fix viscous / fix langevin formulas."""
import sys, numpy as np
def frames(fn):
    out=[]; L=open(fn).read().split("ITEM: TIMESTEP")[1:]
    for b in L:
        lines=b.strip().split("\n"); i=[k for k,l in enumerate(lines) if l.startswith("ITEM: ATOMS")][0]
        out.append(np.array([[float(x) for x in l.split()] for l in lines[i+1:]]))
    return out
dt=1e-6
mode=sys.argv[1]; damp=float(sys.argv[2]) if len(sys.argv)>2 else 2.0
f0,f1=frames("dump."+mode)
r=f0[:,2]; m=f0[:,3]; typ=f0[:,1]; I=0.4*m*r*r
s=np.where(typ==1,0.5,1.0)
# v1 = v0*(1 - c dt/m + (c dt/m)^2/2) for velocity Verlet with post_force drag
def est(v0,v1,mm):
    q=v1/v0            # = (1 - x/2)^2 , x=c dt/m (drag evaluated on half-step v)
    x=2*(1-np.sqrt(q))
    return x*mm/dt
ct=np.array([est(f0[:,4+k],f1[:,4+k],m) for k in range(3)]).mean(0)
cr=np.array([est(f0[:,7+k],f1[:,7+k],I) for k in range(3)]).mean(0)
if mode.endswith("viscous"):
    print("transl c / (gamma*scale):", np.unique(np.round(ct/(1.0*s),6)))
    print("rot c:", np.unique(np.round(cr,9)))
elif mode=="langevin":
    print("transl c / (m/(DAMP*scale)):", np.unique(np.round(ct/(m/(damp*s)),6)))
    print("rot c / (I/(DAMP*scale)):", np.unique(np.round(cr/(I/(damp*s)),6)))
else:
    print("transl:", np.unique(np.round(ct,9)), "rot:", np.unique(np.round(cr,9)))
