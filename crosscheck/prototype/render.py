#!/usr/bin/python3
"""Reference implementation of the template translator (what celldem's C++
translator must reproduce).

usage: render.py TEMPLATE DATAFILE OUT.in KEY=VALUE ...
  required keys : KN KT MU DT ALPHA NSTEPS OUT_EVERY OUT
  axis keys     : AX1 AX2 AX3  each  "strain:DELTA"  (compression per step, may be 0)
                                or   "stress:SIGMA"  (target contact stress, Pa, compression +)
  optional      : SKIN (default 0.1*dmin)  LDAMP (1.0)  PDAMP (1e-3)  MODULUS (1e8)
                  SERVO_SHIFT (LIGGGHTS: initial box lengths captured in script, see template)
Per-type body damping is derived from the data file (diameter, density of each type).
"""
import math, re, sys

tpl, data, out = sys.argv[1:4]
kv = dict(a.split("=", 1) for a in sys.argv[4:])
KN, KT, ALPHA, DT = (float(kv[k]) for k in ("KN", "KT", "ALPHA", "DT"))
LDAMP = float(kv.setdefault("LDAMP", "1.0"))
kv.setdefault("PDAMP", "1e-3")
kv.setdefault("MODULUS", "1e8")
REMAP = kv.setdefault("REMAP", "x")          # LAMMPS only: x (default) or v

# ---- per-type diameter / density from the data file -------------------------
types = {}
sec = None
for line in open(data):
    s = line.split("#")[0].strip()
    if not s:
        continue
    if re.match(r"^[A-Z][A-Za-z ]*$", s):
        sec = s
        continue
    if sec == "Atoms":
        f = s.split()
        t, d, rho = int(f[1]), float(f[2]), float(f[3])
        if t in types and (abs(types[t][0] - d) > 1e-12 * d or types[t][1] != rho):
            sys.exit("type %d has more than one diameter/density: per-type damping impossible" % t)
        types[t] = (d, rho)
ntypes = max(types)
kv.setdefault("SKIN", "%.6g" % (0.1 * min(d for d, _ in types.values())))

lang, visc, visc_all, lang2 = [], [], [], []
for t in range(1, ntypes + 1):
    if t not in types:             # unused type: any positive value
        lang.append("scale %d 1.0" % t); lang2.append("scale %d 1.0" % t); visc.append("scale %d 0.0" % t); visc_all.append("scale %d 0.0" % t)
        continue
    d, rho = types[t]
    r = 0.5 * d
    m = rho * math.pi / 6.0 * d ** 3
    I = 0.4 * m * r * r
    ct = ALPHA * 2.0 * math.sqrt(m * KN)            # paper: fraction of 2 sqrt(m kn)
    cr = ALPHA * 2.0 * r * math.sqrt(I * KT)        # paper: fraction of 2 r sqrt(I kt)
    s = (10.0 / 3.0) * I / (LDAMP * cr)             # langevin: c_rot = 10/3 I/(LDAMP s)
    g = ct - m / (LDAMP * s)                        # langevin gives m/(LDAMP s) of c_t
    if g < 0:
        sys.exit("kt/kn too large: langevin translational drag exceeds c_t")
    lang.append("scale %d %.17g" % (t, s))
    lang2.append("scale %d %.17g" % (t, m / (LDAMP * g)))   # 2nd langevin = viscous g
    visc.append("scale %d %.17g" % (t, g))
    visc_all.append("scale %d %.17g" % (t, ct))
kv["LANGEVIN_SCALES"] = " ".join(lang)
kv["VISCOUS_SCALES"] = " ".join(visc)
kv["LANGEVIN2_SCALES"] = " ".join(lang2)        # LAMMPS remap v: translational remainder          # LAMMPS: remainder after langevin
kv["VISCOUS_SCALES_FULL"] = " ".join(visc_all)  # LIGGGHTS: full c_t (no rotational drag)
kv["NTYPES"] = str(ntypes)
for key, val in (("KN_MAT", kv["KN"]), ("KT_MAT", kv["KT"]), ("MU_MAT", kv["MU"]), ("ZERO_MAT", "0.0")):
    kv[key] = " ".join([val] * (ntypes * ntypes))   # LIGGGHTS peratomtypepair N*N
kv["NTYPES2"] = str(ntypes * ntypes)

# ---- axis control ------------------------------------------------------------
deform, baro, have_strain, have_stress = [], [], False, False
v_deform, v_ramps, v_vars = [], [], []
lig_deform, lig_vars = [], []
comp = {"x": 1, "y": 2, "z": 3}
for i, ax in enumerate("xyz"):
    mode, val = kv["AX%d" % (i + 1)].split(":")
    if mode == "strain":
        have_strain = True
        erate = -float(val) / DT
        if erate == 0.0:   # fixed axis: simply not deformed
            continue
        v_deform.append("%s erate %.17g" % (ax, erate))
        # remap v: particles must carry the affine streaming velocity erate*(x - x_center)
        v_ramps.append("velocity        all ramp v%s $(%.17g*l%s) $(%.17g*l%s) %s $(%slo) $(%shi) sum yes units box"
                       % (ax, -0.5 * erate, ax, 0.5 * erate, ax, ax, ax, ax))
        deform.append("%s erate %.17g" % (ax, erate))
        lig_deform.append("%s erate %.17g" % (ax, erate))
    elif mode == "stress":
        have_stress = True
        baro.append("%s %s %s %s" % (ax, val, val, kv["PDAMP"]))
        # LIGGGHTS servo (identical law to press/berendsen):
        #   L_new = L*(1 - DT/PDAMP*(target - P)/MODULUS)^(1/3); fix deform variable
        #   takes the change relative to the box length at the start of the run.
        lig_vars.append(
            "variable        L0%s equal ${L%snow}\n"
            "variable        d%s equal l%s*(1.0-%s/%s*(%s-c_P[%d])/%s)^(1.0/3.0)-v_L0%s\n"
            "variable        r%s equal 0.0"
            % (ax, ax, ax, ax, kv["DT"], kv["PDAMP"], val, comp[ax], kv["MODULUS"], ax, ax))
        lig_deform.append("%s variable v_d%s v_r%s" % (ax, ax, ax))
        v_deform.append("%s variable v_d%s v_r%s" % (ax, ax, ax))
        # same servo law; h_rate = actual rate so ghost velocities / temp/deform bias follow it
        v_vars.append(
            "variable        L%snow equal l%s\n"
            "variable        L0%s equal ${L%snow}\n"
            "variable        f%s equal (1.0-%s/%s*(%s-c_P[%d])/%s)^(1.0/3.0)\n"
            "variable        d%s equal l%s*v_f%s-v_L0%s\n"
            "variable        r%s equal l%s*(v_f%s-1.0)/%s"
            % (ax, ax, ax, ax, ax, kv["DT"], kv["PDAMP"], val, comp[ax], kv["MODULUS"],
               ax, ax, ax, ax, ax, ax, ax, kv["DT"]))
    else:
        sys.exit("bad axis spec " + kv["AX%d" % (i + 1)])
kv["DEFORM_ARGS"] = " ".join(deform)
kv["BARO_ARGS"] = " ".join(baro)
kv["LIG_DEFORM_ARGS"] = " ".join(lig_deform)
kv["V_DEFORM_ARGS"] = " ".join(v_deform)
kv["V_RAMPS"] = "\n".join(v_ramps) if v_ramps else "# (no strain axis: no streaming velocity ramp)"
kv["V_SERVO_VARS"] = "\n".join(v_vars) if v_vars else "# (no stress axis)"
kv["LIG_SERVO_VARS"] = "\n".join(lig_vars)

# ---- substitute ----------------------------------------------------------------
kv["DATA"] = data
txt = open(tpl).read()
flags = {"STRAIN": have_strain, "STRESS": have_stress, "ANY": have_strain or have_stress,
         "REMAPX": REMAP == "x", "REMAPV": REMAP == "v"}
lines = []
for line in txt.splitlines():
    mo = re.match(r"^#\?([A-Z+]+) ", line)   # "#?A+B line": keep line if all flags hold
    if mo:
        if not all(flags[f] for f in mo.group(1).split("+")):
            continue
        line = line[mo.end():]
    lines.append(line)
txt = "\n".join(lines) + "\n"
def fill(line):  # comment lines (template documentation) are left untouched
    if line.lstrip().startswith("#"):
        return line
    for _ in range(3):  # placeholders may contain placeholders
        line = re.sub(r"\{\{([A-Z0-9_]+)\}\}", lambda mo: kv[mo.group(1)], line)
    return line
txt = "\n".join(fill(l) for l in txt.splitlines()) + "\n"
left = [l for l in txt.splitlines() if not l.lstrip().startswith("#") and "{{" in l]
if left:
    sys.exit("unfilled placeholders: %s" % left)
open(out, "w").write(txt)
