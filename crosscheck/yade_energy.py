"""The energy partition of one strain-driven test in YADE, for docs/energy.md's comparison with celldem's budget.

Run by crosscheck/yade_energy.sh (yade -x -n crosscheck/yade_energy.py PACKING.json OUT.json): PACKING.json holds
the cell, radii, positions and fluctuating velocities of celldem's test start (its ascii snapshot) and the
physics (kn, kt, mu, density, dt, the cell's velocity gradient, steps). Equal spheres, so that YADE's
Ip2_FrictMat_FrictMat_FrictPhys gives celldem's kn (kn = 2 E r1 r2/(r1 + r2) = E r) and kt = poisson kn; no damping.
YADE's Law2_ScGeom_FrictPhys_CundallStrack traces the elastic potential and the plastic dissipation; the boundary
work is summed here each step as -dt L : (M_old + M_new)/2 from the contacts' forces and branches, as celldem does.
"""
import json
import math
import sys

from yade import *  # noqa: F401,F403  (yade's own namespace: O, sphere, engines)
from yade import utils

packing, out_path = sys.argv[1], sys.argv[2]
P = json.load(open(packing))
r = P["radius"]
O.periodic = True
O.cell.hSize = Matrix3(*[x for row in P["h"] for x in row])
mat = O.materials.append(FrictMat(young=P["kn"] / r, poisson=P["kt"] / P["kn"], frictionAngle=math.atan(P["mu"]),
                                  density=P["density"]))
for x, v, w in zip(P["positions"], P["velocities"], P["spins"]):
    b = O.bodies.append(sphere(Vector3(*x), r, material=mat))
    O.bodies[b].state.vel = Vector3(*v)
    O.bodies[b].state.angVel = Vector3(*w)
L = Matrix3(*[x for row in P["velocity_gradient"] for x in row])
state = {"work": 0.0, "M": None}


def moment():
    """sum f (x) l over the contacts, f the force on body 2 (repulsion along +l), l = x2 - x1 across the image."""
    M = Matrix3.Zero
    for i in O.interactions:
        if not i.isReal:
            continue
        l = O.bodies[i.id2].state.pos - O.bodies[i.id1].state.pos + O.cell.hSize * i.cellDist
        f = i.phys.normalForce + i.phys.shearForce
        M = M + f.outer(l)
    return M


def fast_moment():
    """The same from YADE's own (C++) Love-Weber stress: -V getStress() (tension positive there), checked against
    moment() at the start."""
    return -O.cell.volume * utils.getStress()


def boundary_work():
    M = fast_moment()
    if state["M"] is not None:
        mean = 0.5 * (state["M"] + M)
        state["work"] -= O.dt * sum(L[a, b] * mean[a, b] for a in range(3) for b in range(3))
    state["M"] = M


O.engines = [
    ForceResetter(),
    InsertionSortCollider([Bo1_Sphere_Aabb()], verletDist=0.1 * r),
    InteractionLoop([Ig2_Sphere_Sphere_ScGeom()], [Ip2_FrictMat_FrictMat_FrictPhys()],
                    [Law2_ScGeom_FrictPhys_CundallStrack(traceEnergy=True)]),
    PyRunner(command="boundary_work()", iterPeriod=1),
    NewtonIntegrator(damping=0.0),
]
O.engines[2].lawDispatcher.functors[0].traceEnergy = True  # (a static attribute: set on the instance too)
O.dt = P["dt"]
O.trackEnergy = True
O.cell.velGrad = L
O.step()  # the first step makes the contacts: the start's energies are measured after it
slow, fast = moment(), fast_moment()
assert abs(slow.trace() - fast.trace()) <= 1e-9 * abs(slow.trace()), (slow, fast)
start = dict(O.energy.items())
work0 = state["work"]
O.run(P["steps"] - 1, True)
end = dict(O.energy.items())
result = {"start": start, "end": end, "boundary_work": state["work"] - work0, "steps": P["steps"],
          "kinetic_fluctuating": sum(0.5 * b.state.mass * (b.state.vel - L * b.state.pos).squaredNorm()
                                     for b in O.bodies),
          "kinetic_rotation": sum(0.5 * b.state.inertia[0] * b.state.angVel.squaredNorm() for b in O.bodies)}
json.dump(result, open(out_path, "w"), indent=1)
print("YADE", json.dumps(result))
sys.exit(0)
