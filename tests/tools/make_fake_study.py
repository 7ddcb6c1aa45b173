#!/usr/bin/python3
"""Writes a synthetic study root (the run folders tools/study.py leaves) with known answers, for tests/tools/test_study_analysis.py.

Usage: /usr/bin/python3 tests/tools/make_fake_study.py ROOT

Four reference runs (seeds 1-4) whose compared quantities have a known spread, and settings whose TTC peak
σ1/σ3 is off their paired reference by a known amount, with known CPU times; two stability runs (one blows up)
and a servo run with a known stress error. ROOT/expected.json holds the noise floor, the normalised errors, the
Pareto front and the presets the analysis must find.

Each run folder gets what tools/study.py and celldem leave there: spec.json, outcome.json, <test>/series.csv,
summary.json (its per-test quantities from `celldem summarize` of each series, the one definition, and the
settings) and plan.json (what `celldem plan` prints for the run's deck: steps, time step ratio, inertial number,
particle masses, written here so that no deck is planned). The built binary must exist (tools/build.sh).
"""

import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
from celldem import binary
from celldem.study import runs as study
from celldem.study import scene as sa

COLUMNS = ("step", "time", "e1", "e2", "e3", "ev", "s11", "s22", "s33", "s12", "s13", "s23", "p", "q", "ratio13",
           "b", "Z", "kinetic_energy", "void_ratio")
E1 = np.round(np.linspace(0.0, sa.END_STRAIN, 151), 10)   # rows every 2e-4; peaks fall on grid points

# Reference quantities per seed: (peak σ1/σ3, ε1 at peak, εv at end, Z at end) of TTC and PSC, and PSC b at peak.
REF = {
    1: {"ttc": (2.90, 0.0050, -0.020, 4.30), "psc": (3.40, 0.0040, -0.025, 4.20), "b": 0.40},
    2: {"ttc": (3.00, 0.0060, -0.022, 4.25), "psc": (3.50, 0.0044, -0.027, 4.22), "b": 0.38},
    3: {"ttc": (3.10, 0.0056, -0.018, 4.35), "psc": (3.45, 0.0050, -0.026, 4.18), "b": 0.42},
    4: {"ttc": (3.00, 0.0064, -0.020, 4.30), "psc": (3.55, 0.0046, -0.024, 4.20), "b": 0.40},
}
# Settings: TTC peak offset from the paired reference per seed, and CPU seconds.
SETTINGS = {
    "inc_1e-06": {"offsets": (0.03, 0.01), "cpu": 20.0, "inc": 1e-6},
    "inc_1e-05": {"offsets": (0.40, 0.20), "cpu": 2.0, "inc": 1e-5},
    "dt_3e-06": {"offsets": (0.09, 0.01), "cpu": 30.0, "inc": 6e-7, "dt": 3e-6},
    "combo_dt3e-06_inc3e-06": {"offsets": (0.12, 0.00), "cpu": 10.0, "inc": 3e-6, "dt": 3e-6, "ev_floors": 1.5},
}
REF_CPU = 100.0

# What `celldem plan inputs/paper.json --json` prints for the paper's spheres (test data: celldem computes these).
TC = 6.12074279757435e-06                         # [s] sqrt(m_min / kn)
DIAMETERS = np.linspace(3.0e-3, 4.5e-3, 16)       # [m] the paper's 16 sizes
DENSITY = 2650.0                                  # [kg/m^3]
DEFAULT_SERVO_CAP = 1.0e-6                        # celldem's default servo.max_strain_increment
END_WINDOW = 0.005                                # celldem's end window: the last 0.5 % of ε1
# The time step's bounds as fractions of the critical time step: celldem's table (`celldem plan --json`).
BOUND_FRACTIONS = [{k: v for k, v in b.items() if k != "time_step"}
                   for b in binary.plan(os.path.join(binary.REPO, "inputs", "paper.json"))["time_step_bounds"]]


def series(peak, e_peak, ev_end, z_end, b_peak=None, s22_noise=None, blow_up=False, ke_level=1e-7):
    x = E1 / e_peak
    ratio = 1.0 + (peak - 1.0) * np.where(E1 <= e_peak, x * np.exp(1.0 - x), 1.0 - 0.1 * (E1 - e_peak) / 0.03)
    ev = ev_end * E1 / sa.END_STRAIN
    z = 6.0 + (z_end - 6.0) * E1 / sa.END_STRAIN
    s33 = np.full_like(E1, 1e5)
    s11 = ratio * s33
    b = np.zeros_like(E1) if b_peak is None else b_peak * (ratio - 1.0) / (peak - 1.0)
    s22 = s33 + b * (s11 - s33)
    if s22_noise is not None:
        s22 = s22 * (1.0 + s22_noise)
    ke = np.full_like(E1, ke_level)     # [J]; p V of the scene is about 4.7 J
    if blow_up:
        ke = 1e-7 * np.exp(E1 / 0.001)
        ke[-5:] = np.nan
    cols = {"step": np.arange(E1.size) * 1000.0, "time": np.arange(E1.size) * 1e-3, "e1": E1, "e2": -E1 / 2,
            "e3": -E1 / 2, "ev": ev, "s11": s11, "s22": s22, "s33": s33, "s12": 0 * E1, "s13": 0 * E1,
            "s23": 0 * E1, "p": (s11 + s22 + s33) / 3, "q": s11 - s33, "ratio13": ratio, "b": b, "Z": z,
            "kinetic_energy": ke, "void_ratio": np.full_like(E1, 0.6)}
    if blow_up:
        for c in ("s11", "ratio13"):
            cols[c][-5:] = np.nan
    return cols


def fake_plan(spec):
    """plan.json of a spec's deck, as `celldem plan --json` would print it (the fields the analysis reads)."""
    density = DENSITY * spec.get("density_factor", 1.0)
    masses = density * math.pi / 6.0 * DIAMETERS ** 3
    d_mean = float(np.mean(DIAMETERS))
    rate = spec.get("strain_increment", 0.0) / spec["time_step"]
    tests = [{"name": name, "end_axis": "x1", "steps": int(round(spec["end_strain"] / spec["strain_increment"])),
              "strain_per_step": spec["strain_increment"], "strain_rate": rate,
              "inertial_number": rate * d_mean * math.sqrt(density / sa.P_REF),
              "axes": {"x1": {"strain_increment": spec["strain_increment"]}, "x2": {"stress": sa.P_REF},
                       "x3": {"stress": sa.P_REF}}} for name in spec.get("tests", [])]
    critical = TC * math.sqrt(spec.get("density_factor", 1.0))
    return {"time_step": spec["time_step"], "critical_time_step": critical,
            "time_step_ratio": spec["time_step"] / critical,
            "time_step_bounds": [dict(b, time_step=b["fraction"] * critical) for b in BOUND_FRACTIONS],
            "sample": {"count": spec["count"], "density": density, "mean_diameter": d_mean},
            "particle_types": [{"diameter": float(d), "mass": float(m)} for d, m in zip(DIAMETERS, masses)],
            "tests": tests}


def write_run(root, spec, tests, cpu, rc=0):
    d = os.path.join(root, "samples" if spec["kind"] == "sample" else "runs", spec["name"])
    os.makedirs(d, exist_ok=True)
    for name, cols in tests.items():
        os.makedirs(os.path.join(d, name), exist_ok=True)
        with open(os.path.join(d, name, "series.csv"), "w", encoding="utf-8") as f:
            f.write(",".join(COLUMNS) + "\n")
            for i in range(E1.size):
                f.write(",".join(repr(float(cols[c][i])) for c in COLUMNS) + "\n")
    with open(os.path.join(d, "spec.json"), "w", encoding="utf-8") as f:
        json.dump(spec, f)
    cap = (spec.get("servo") or {}).get("max_strain_increment", DEFAULT_SERVO_CAP)
    if spec["kind"] == "sample":
        cap = spec.get("servo_cap") or DEFAULT_SERVO_CAP
    summary = {"settings": {"time_step": spec["time_step"], "servo_max_strain_increment": cap},
               "tests": {t: dict(binary.summarize(os.path.join(d, t, "series.csv")), wall_s=1.5 * cpu / max(len(tests), 1))
                         for t in tests}}
    with open(os.path.join(d, "summary.json"), "w", encoding="utf-8") as f:
        json.dump(summary, f)
    with open(os.path.join(d, "plan.json"), "w", encoding="utf-8") as f:
        json.dump(fake_plan(spec), f)
    with open(os.path.join(d, "outcome.json"), "w", encoding="utf-8") as f:
        json.dump({"rc": rc, "cpu_s": cpu, "wall_s": 1.5 * cpu, "host": "fake", "log_tail": ""}, f)


TTC_EV_STD = float(np.std([REF[s]["ttc"][2] for s in REF], ddof=1))


def ref_tests(seed, ttc_offset=0.0, ev_floors=0.0):
    """The reference's series of `seed`, with TTC's peak raised by ttc_offset and its εv by ev_floors noise floors."""
    r = REF[seed]
    peak, e_peak, ev_end, z_end = r["ttc"]
    return {"ttc": series(peak + ttc_offset, e_peak, ev_end + ev_floors * TTC_EV_STD, z_end),
            "psc": series(*r["psc"], b_peak=r["b"])}


def main():
    root = sys.argv[1]
    os.makedirs(root, exist_ok=True)
    for seed in REF:
        write_run(root, study.sample_spec(seed=seed), {}, 10.0)
        write_run(root, study.test_spec(f"ref_s{seed}", "reference", "ref", 1, seed=seed, role="reference"),
                  ref_tests(seed), REF_CPU)
    for key, s in SETTINGS.items():
        group = {"inc": "strain_increment", "dt_": "time_step", "com": "combined"}[key[:3] if key[:3] != "dt_" else "dt_"]
        for seed, off in zip((1, 2), s["offsets"]):
            spec = study.test_spec(f"{key}_s{seed}", group, key, 2, seed=seed, strain_increment=s["inc"],
                                   time_step=s.get("dt", sa.PAPER_DT))
            write_run(root, spec, ref_tests(seed, off, s.get("ev_floors", 0.0)), s["cpu"])
    # Samples prepared as the preset candidates' decks would prepare them (their dt and servo cap 5 × Δε1), then
    # the paper's tests: the reference's own curves, so their errors against the reference mean stay inside the
    # floor and those candidates are allowed.
    for dt, cap in ((3e-6, 1.5e-5), (sa.PAPER_DT, 5e-6)):
        for seed in (1, 2):
            spec = study.test_spec(f"prep_{dt:g}_{cap:g}_s{seed}", "prepare_dt", "prep", 9, seed=seed, sample_dt=dt,
                                   sample_cap=cap, knob="prepare_dt", value=dt)
            write_run(root, spec, ref_tests(seed), REF_CPU)
    # Stability: a stable run at the paper's dt, a hot one (kinetic energy 1e-3 p V) at 0.65 t_c, and one that
    # blows up (non-finite values) at 0.9 t_c.
    tc = TC
    for frac, blow, ke in ((sa.PAPER_DT / tc, False, 1e-7), (0.65, False, 5e-3), (0.9, True, 1e-7)):
        dt = sa.PAPER_DT if frac < 0.2 else frac * tc
        spec = study.test_spec(f"stab_f{frac:.3g}_a0.05", "stability_dt", "stab", 7, time_step=dt,
                               strain_increment=sa.PAPER_RATE * dt, tests=("ttc",), end_strain=sa.END_STRAIN,
                               role="stability", knob="dt_fraction", value=frac)
        r = REF[1]["ttc"]
        write_run(root, spec, {"ttc": series(*r, blow_up=blow, ke_level=ke)}, 5.0)
    # Servo: σ22 off its target by ±1 % alternately (std 1 %, mean 0), σ33 exact.
    noise = np.where(np.arange(E1.size) % 2 == 0, 0.01, -0.01)
    spec = study.test_spec("servo_g0.5_i0", "stability_servo", "servo", 8, tests=("ttc",), role="stability",
                           strain_increment=sa.SERVO_INC, output_interval=sa.SERVO_OUTPUT_INTERVAL,
                           servo={"gain": 0.5, "integral_gain": 0.0}, knob="servo", value=[0.5, 0.0])
    write_run(root, spec, {"ttc": series(*REF[1]["ttc"], s22_noise=noise)}, 5.0)

    # The answers.
    ttc_peaks = [REF[s]["ttc"][0] for s in REF]
    floor = float(np.std(ttc_peaks, ddof=1))
    # The score: the largest of the TTC peak's error (mean over the seeds) and the TTC εv error, in floors.
    errors = {k: max(abs(sum(s["offsets"]) / 2) / floor, s.get("ev_floors", 0.0)) for k, s in SETTINGS.items()}
    keep = noise[int(E1.size * 0.1):]
    servo_std = float(np.std(np.concatenate([keep, np.zeros_like(keep)])))
    expected = {
        "floor_ttc_peak": floor,
        "floor_psc_b": float(np.std([REF[s]["b"] for s in REF], ddof=1)),
        # εv is linear in ε1 here, so its mean over the end window is its end value × the window's mean ε1 / END.
        "floor_ttc_ev_end": float(np.std([REF[s]["ttc"][2] for s in REF], ddof=1))
        * float(np.mean(E1[np.abs(E1 - E1[-1]) <= END_WINDOW])) / sa.END_STRAIN,
        "scores": errors,
        "pareto": sorted(["reference", "inc_1e-06", "combo_dt3e-06_inc3e-06", "inc_1e-05"]),
        "fast": "combo_dt3e-06_inc3e-06",       # cheapest with stress errors ≤ 1 floor, εv and Z ≤ 2 floors
        "balanced": "inc_1e-06",                # cheapest with every error ≤ 1 floor
        "servo_std": servo_std,
        "stability": {"stab_f0.163_a0.05": "stable", "stab_f0.65_a0.05": "unstable", "stab_f0.9_a0.05": "blow-up"},
    }
    with open(os.path.join(root, "expected.json"), "w", encoding="utf-8") as f:
        json.dump(expected, f, indent=1)


if __name__ == "__main__":
    main()
