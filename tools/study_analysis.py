#!/usr/bin/python3
"""The analysis half of tools/study.py: the reduced scene's constants, the compared quantities, the noise floor,
the errors, the Pareto front, the presets' choice, the stability measures, the charts and study.md.

Everything here is a function of the run folders under the study root (spec.json, outcome.json, summary.json,
<test>/series.csv), so tests/tools/test_study.sh can check it on synthetic results without running celldem.
"""

import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import celldem_results as cr  # noqa: E402
from celldem_results import fmt  # noqa: E402

# ---- the scene and the paper's settings ---------------------------------------------------------------------

SCENE_COUNT = 1000          # spheres in the reduced scene (the paper: 8000)
END_STRAIN = 0.03           # ε1 at which the reduced tests end (the paper: 10 %); end values are read here
REF_SEEDS = tuple(range(1, 9))  # reference samples: the noise floor is their seed-to-seed spread
PAPER_DT = 1.0e-6           # [s] paper time step
PAPER_INC = 2.0e-7          # paper axial strain increment per step
PAPER_RATE = PAPER_INC / PAPER_DT   # [1/s] paper axial strain rate
PAPER_DAMPING = 0.05        # paper damping fraction, translational and rotational
ROW_STRAIN = 2.0e-4         # ε1 between series rows: the paper's 1000 steps × 2e-7
P_REF = 1.0e5               # [Pa] confining stress, the p of the inertial number
QUASI_STATIC_I = 1.0e-3     # the usual quasi-static limit of the inertial number
SERVO_TOLERANCE = 0.005     # a stress-controlled axis "holds" when its relative error std stays below 0.5 %
STABILITY_STRAIN = 0.01     # ε1 of the short time step × damping runs
SERVO_STRAIN = 0.015        # the servo runs: ε1 at the end, strain increment per step, steps between rows
SERVO_INC = 5.0e-7
SERVO_OUTPUT_INTERVAL = 25
DEFAULT_SERVO_CAP = 1.0e-6  # celldem's default servo.max_strain_increment
SERVO_CAP_FACTOR = 5.0      # the study's servo.max_strain_increment: 5 × Δε1 (the paper: 5 × 2e-7 = the default)

END_WINDOW = 0.005          # εv and Z "at the end": their mean over the last 0.5 % of ε1 before END_STRAIN
# The quantities compared, (test, name). e1_peak, b_peak at the row of max σ1/σ3; *_end over the END_WINDOW.
QUANTITIES = (
    ("ttc", "peak_ratio"), ("ttc", "e1_peak"), ("ttc", "ev_end"), ("ttc", "Z_end"),
    ("psc", "peak_ratio"), ("psc", "e1_peak"), ("psc", "ev_end"), ("psc", "Z_end"), ("psc", "b_peak"),
)
QUANTITY_LABELS = {
    "peak_ratio": "peak σ1/σ3", "e1_peak": "ε1 at peak", "ev_end": "εv at the end", "Z_end": "Z at the end",
    "b_peak": "b at peak",
}
MODELLING_QUANTITIES = (("ttc", "peak_ratio"), ("ttc", "ev_end"), ("ttc", "Z_end"))

# The stress-ratio quantities (the paper's strength results) and the volumetric and contact ones.
STRESS_QUANTITIES = (("ttc", "peak_ratio"), ("ttc", "e1_peak"), ("psc", "peak_ratio"), ("psc", "e1_peak"),
                     ("psc", "b_peak"))
# Presets: "balanced" keeps every quantity inside the noise floor; "fast" the stress-ratio ones, with εv and Z
# (which a faster loading shifts first) allowed two floors.
PRESET_RULES = {
    "fast": {"stress": 1.0, "volume": 2.0,
             "text": "peak σ1/σ3, ε1 at peak and b inside the noise floor; εv and Z within 2 floors"},
    "balanced": {"stress": 1.0, "volume": 1.0, "text": "every compared quantity inside the noise floor"},
}
DRIFT_FLOORS = 3.0          # a short stability run "drifts" when σ1/σ3 moves by more than 3 TTC peak floors
KE_UNSTABLE = 1.0e-4        # kinetic energy / (p V) above which a run is dynamic (quasi-static runs: ~1e-6)


def diameters_of(deck):
    d = deck["sample"]["diameters"]
    if "list" in d:
        return [float(x) for x in d["list"]]
    n = int(d["count"])
    return [float(x) for x in np.linspace(d["min"], d["max"], n)] if n > 1 else [float(d["min"])]


def critical_step(deck, density=None):
    """sqrt(m_min/kn) [s], the deck validation's limit on time_step."""
    rho = deck["sample"]["density"] if density is None else density
    d_min = min(diameters_of(deck))
    m_min = rho * math.pi / 6.0 * d_min ** 3
    return math.sqrt(m_min / deck["contact"]["kn"])


def inertial_number(rate, d_mean, density, p=P_REF):
    """I = ε̇ d sqrt(ρ/p): the ratio of the time to rearrange a grain under p to the loading time."""
    return abs(rate) * d_mean * math.sqrt(density / p)


def read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, json.JSONDecodeError):
        return None


# ---- analysis: pure functions of run metrics (tested by tests/tools/test_study.sh) ---------------------------

def test_metrics(series, end_strain):
    """The compared quantities of one test's series (dict of column -> array); None where not measurable."""
    e1 = cr.column(series, "e1")
    ratio = cr.column(series, "ratio13")
    i = cr.peak_index(ratio)
    out = {"peak_ratio": None, "e1_peak": None, "b_peak": None, "ev_end": None, "Z_end": None, "e1_final": None,
           "finite": bool(all(np.all(np.isfinite(series[c])) for c in ("e1", "s11", "s22", "s33") if c in series))}
    if e1 is None or not e1.size:
        return out
    out["e1_final"] = float(np.nanmax(e1))
    if i is not None:
        out["peak_ratio"] = float(ratio[i])
        out["e1_peak"] = float(e1[i])
        b = cr.column(series, "b")
        out["b_peak"] = None if b is None or not math.isfinite(b[i]) else float(b[i])
    # End values: the mean over the last END_WINDOW of ε1 (a single row of Z jumps by a few hundredths from row to
    # row as contacts open and close). The run must have reached the end strain (up to the rounding of its steps).
    if out["e1_final"] < end_strain * (1 - 1e-3):
        return out
    lo, hi = end_strain - END_WINDOW, min(end_strain, out["e1_final"])
    inside = (e1 >= lo - 1e-12) & (e1 <= hi + 1e-12)
    for key, name in (("ev_end", "ev"), ("Z_end", "Z")):
        y = cr.column(series, name)
        if y is None:
            continue
        window = y[inside & np.isfinite(y)]
        out[key] = float(np.mean(window)) if window.size else cr.value_at(e1, y, hi)
    return out


def kinetic_ratio(series, count, mean_d3):
    """Kinetic energy / (p V) per row, V = solid volume (count spheres of mean d³) × (1 + e); None without columns."""
    ke, void = series.get("kinetic_energy"), series.get("void_ratio")
    if ke is None or void is None:
        return None
    return ke / (P_REF * count * math.pi / 6.0 * mean_d3 * (1.0 + void))


def noise_floor(reference_metrics, quantities=QUANTITIES):
    """Mean and seed-to-seed standard deviation (ddof 1) of each quantity over the reference samples."""
    mean, std = {}, {}
    for q in quantities:
        values = [m[q[0]][q[1]] for m in reference_metrics
                  if m.get(q[0]) is not None and m[q[0]].get(q[1]) is not None]
        mean[q] = float(np.mean(values)) if values else None
        std[q] = float(np.std(values, ddof=1)) if len(values) >= 2 else None
    return mean, std


def errors_against(metrics, reference, floor, quantities=QUANTITIES):
    """{q: (error, error / floor)} for the quantities both runs have; `reference` maps test -> name -> value."""
    out = {}
    for q in quantities:
        test, name = q
        v = (metrics.get(test) or {}).get(name)
        r = (reference.get(test) or {}).get(name)
        if v is None or r is None:
            continue
        err = v - r
        f = floor.get(q)
        out[q] = (err, abs(err) / f if f else None)
    return out


def combine_seeds(per_seed_errors, floor, quantities=QUANTITIES):
    """The systematic error of a setting: the mean over its seeds of the signed paired differences, and |mean| / floor.

    DEM is chaotic: any change of setting (even dt in its 9th digit) sends a run down another path, so single paired
    differences scatter by about the seed-to-seed spread even when the setting is exact. The mean over seeds keeps
    what the setting shifts and averages that scatter out."""
    out = {}
    for q in quantities:
        errs = [e[q][0] for e in per_seed_errors if q in e]
        if not errs:
            continue
        bias = sum(errs) / len(errs)
        f = floor.get(q)
        out[q] = (bias, abs(bias) / f if f else None)
    return out


def score_of(errors):
    """The largest normalised error: below 1, the setting is inside the noise floor for every quantity."""
    values = [n for _, n in errors.values() if n is not None]
    return max(values) if values else None


def pareto_front(points):
    """Indices of the points (cost, error) that no other point beats in both (lower is better); sorted by cost."""
    idx = [i for i, (c, e) in enumerate(points) if c is not None and e is not None]
    front = []
    for i in idx:
        ci, ei = points[i]
        dominated = any((points[j][0] <= ci and points[j][1] <= ei) and (points[j][0] < ci or points[j][1] < ei)
                        for j in idx if j != i)
        if not dominated:
            front.append(i)
    return sorted(front, key=lambda i: (points[i][0], points[i][1]))


def cheapest_within(rows, limit, score_key="score", cost_key="cost", also=None):
    """The row with the smallest cost whose `score_key` ≤ limit (and `also(row)` if given); None if there is none.
    Rows without a score or a cost are not candidates."""
    ok = [r for r in rows if r.get(score_key) is not None and r[score_key] <= limit and r.get(cost_key) is not None
          and (also is None or also(r))]
    return min(ok, key=lambda r: (r[cost_key], r[score_key])) if ok else None


def meets(row, rule):
    """Whether a setting's errors meet a preset rule {"stress": limit, "volume": limit}."""
    return (row.get("score_stress") is not None and row["score_stress"] <= rule["stress"]
            and row.get("score_volume") is not None and row["score_volume"] <= rule["volume"])


def preparation_ok(rows, time_step, servo_cap, rule):
    """A preset's deck prepares its sample with its own time step and servo cap: fine with the paper's, else only
    where a sample prepared with those, run with the paper's tests, meets the same rule (unknown is not fine)."""
    def same(a, b):
        return abs(a - b) <= 1e-9 * max(abs(a), abs(b))
    if same(time_step, PAPER_DT) and same(servo_cap, DEFAULT_SERVO_CAP):
        return True
    checks = [r for r in rows if r["group"] == "prepare_dt" and same(r["sample_time_step"], time_step)
              and same(r["sample_servo_cap"], servo_cap)]
    return bool(checks) and all(meets(r, rule) for r in checks)


def split_scores(errors):
    """(score over the stress-ratio quantities, score over εv and Z) of a setting's errors."""
    stress = {q: v for q, v in errors.items() if q in STRESS_QUANTITIES}
    volume = {q: v for q, v in errors.items() if q not in STRESS_QUANTITIES}
    return score_of(stress), score_of(volume)


def servo_error_stats(series, targets, skip_fraction=0.1):
    """Relative error of the stress-controlled axes after the first `skip_fraction` of the rows: (std, |mean|, max)
    over all those axes; targets maps column (s22, s33) -> target stress."""
    errs = []
    for col, target in targets.items():
        v = series.get(col)
        if v is None or not v.size:
            continue
        start = int(len(v) * skip_fraction)
        errs.append(v[start:] / target - 1.0)
    if not errs:
        return None, None, None
    e = np.concatenate(errs)
    if not np.all(np.isfinite(e)):
        return math.inf, math.inf, math.inf
    return float(np.std(e)), float(abs(np.mean(e))), float(np.max(np.abs(e)))


# ---- analysis: loading the results ------------------------------------------------------------------------------

def load_results(root):
    """spec name -> {"spec", "outcome", "summary", "series" (test -> columns), "metrics" (test -> quantities)}."""
    results = {}
    for kind in ("samples", "runs"):
        base = os.path.join(root, kind)
        if not os.path.isdir(base):
            continue
        for name in sorted(os.listdir(base)):
            d = os.path.join(base, name)
            spec, out = read_json(os.path.join(d, "spec.json")), read_json(os.path.join(d, "outcome.json"))
            if spec is None or out is None:
                continue
            entry = {"spec": spec, "outcome": out, "summary": read_json(os.path.join(d, "summary.json")) or {},
                     "series": {}, "metrics": {}, "dir": d}
            for test in spec.get("tests", []):
                path = os.path.join(d, test, "series.csv")
                if os.path.isfile(path):
                    try:
                        entry["series"][test] = cr.load_series(path)
                    except cr.RunError:
                        continue
                    entry["metrics"][test] = test_metrics(entry["series"][test], spec["end_strain"])
            results[name] = entry
    return results


def run_cost(entry):
    """(cpu_s, wall_s) of a run's tests. CPU time of the single-threaded run is what it costs on an idle core; the
    wall time of a shared machine also counts time given to other jobs."""
    tests = (entry["summary"].get("tests") or {})
    wall = sum(t.get("wall_s", 0.0) for t in tests.values() if isinstance(t, dict)) or entry["outcome"].get("wall_s")
    return entry["outcome"].get("cpu_s"), wall


def steps_of(spec):
    return int(round(spec["end_strain"] / spec["strain_increment"]))


# ---- analysis: the study ------------------------------------------------------------------------------------------

def setting_rows(results, roles, refs, ref_mean, floor, describe, mean_d3):
    """One row per setting (its runs differ only in the seed): errors against the reference, cost, health."""
    settings = {}
    for n, e in results.items():
        spec = e["spec"]
        if spec.get("kind") != "test" or spec.get("role") not in roles:
            continue
        key = "reference" if spec["role"] == "reference" else n.rsplit("_s", 1)[0]
        settings.setdefault(key, []).append(e)
    rows = []
    for key, entries in settings.items():
        spec = entries[0]["spec"]
        good = [e for e in entries if e["outcome"].get("rc") == 0]
        per_seed = []
        for e in good:
            s = e["spec"]
            same_sample = s["count"] == SCENE_COUNT and s.get("sample", "") == f"n{SCENE_COUNT}_s{s['seed']}"
            paired = refs.get(s["seed"]) if same_sample else None
            reference = paired["metrics"] if paired is not None else ref_mean
            per_seed.append(errors_against(e["metrics"], reference, floor))
        errs = combine_seeds(per_seed, floor) if key != "reference" else {q: (0.0, 0.0) for q in QUANTITIES}
        cpu = [run_cost(e)[0] for e in good if run_cost(e)[0] is not None]
        wall = [run_cost(e)[1] for e in good if run_cost(e)[1] is not None]
        finite = all(all(m.get("finite", True) for m in e["metrics"].values()) for e in good)
        # Run-time health of the setting: the largest kinetic energy / (p V) after the first row, and the largest
        # servo error celldem reported per test (summary.json servo_max_error).
        ke_max, servo_max = None, {}
        for e in good:
            for test, ser in e["series"].items():
                k = kinetic_ratio(ser, e["spec"]["count"], mean_d3)
                if k is not None and k.size > 1:
                    ke_max = max(ke_max or 0.0, float(np.nanmax(k[1:])))
                info = (e["summary"].get("tests") or {}).get(test) or {}
                if isinstance(info.get("servo_max_error"), (int, float)):
                    servo_max[test] = max(servo_max.get(test, 0.0), float(info["servo_max_error"]))
        servo = (spec.get("servo") or {}).get("max_strain_increment", DEFAULT_SERVO_CAP)
        row = {"key": key, "group": spec["group"], "label": spec["label"] if key != "reference" else "paper settings",
               "seeds": sorted(e["spec"]["seed"] for e in good), "failed": len(entries) - len(good),
               "count": spec["count"], "time_step": spec["time_step"], "strain_increment": spec["strain_increment"],
               "servo_max_strain_increment": servo, "sample_time_step": spec.get("sample_dt", spec["value"] if spec["group"] == "prepare_dt" else PAPER_DT),
               "sample_servo_cap": spec.get("sample_cap") or DEFAULT_SERVO_CAP,
               "density_factor": spec.get("density_factor", 1.0), "damping": spec["damping"],
               "output_interval": spec["output_interval"], "cost": float(np.mean(cpu)) if cpu else None,
               "wall": float(np.mean(wall)) if wall else None,
               "errors": {f"{t}.{q}": list(v) for (t, q), v in errs.items()},
               "ke_max": ke_max, "servo_max_error": max(servo_max.values()) if servo_max else None,
               "servo_max_error_by_test": servo_max,
               "score": score_of(errs) if good and finite else (None if not good else math.inf)}
        row["score_stress"], row["score_volume"] = split_scores(errs) if finite else (math.inf, math.inf)
        row.update(describe(spec))
        if key == "reference":
            row["score"] = row["score_stress"] = row["score_volume"] = 0.0
        rows.append(row)
    return rows


def analyse(root, paper):
    results = load_results(root)
    tc = critical_step(paper)
    d_mean = float(np.mean(diameters_of(paper)))
    rho = paper["sample"]["density"]
    ok = {n: e for n, e in results.items() if e["outcome"].get("rc") == 0}
    mean_d3 = float(np.mean(np.array(diameters_of(paper)) ** 3))

    refs = {e["spec"]["seed"]: e for n, e in ok.items() if e["spec"].get("role") == "reference"}
    ref_metrics = [refs[s]["metrics"] for s in sorted(refs)]
    mean, floor = noise_floor(ref_metrics)
    ref_mean = {}
    for (test, name), v in mean.items():
        ref_mean.setdefault(test, {})[name] = v

    def describe(spec):
        rate = spec["strain_increment"] / spec["time_step"]
        return {"dt_over_tc": spec["time_step"] / critical_step(paper, rho * spec.get("density_factor", 1.0)),
                "rate": rate,
                "inertial_number": inertial_number(rate, d_mean, rho * spec.get("density_factor", 1.0)),
                "steps_per_test": steps_of(spec)}

    rows = setting_rows(results, ("accuracy", "reference"), refs, ref_mean, floor, describe, mean_d3)
    cap_rows = setting_rows({n: e for n, e in results.items() if e["spec"].get("group") == "servo_cap"},
                            ("stability",), refs, ref_mean, floor, describe, mean_d3)
    group_order = ["reference", "null", "strain_increment", "time_step", "density", "combined", "damping",
                   "output_interval", "count", "prepare_dt"]
    rows.sort(key=lambda r: (group_order.index(r["group"]) if r["group"] in group_order else 99,
                             r["cost"] if r["cost"] is not None else 0))
    points = [(r["cost"], max(r["score"], 1e-3) if r["score"] is not None else None) for r in rows]
    front = pareto_front(points)
    for i, r in enumerate(rows):
        r["pareto"] = i in front

    # Presets: only settings a full deck can carry unchanged otherwise (same count, density, damping, sample prep
    # at the paper's dt unless checked).
    ref_row = next((r for r in rows if r["key"] == "reference"), None)
    # The output interval is left out: its cost differences are within the timing noise (see the table).
    candidates = [r for r in rows if r["group"] in ("reference", "strain_increment", "time_step", "combined")
                  and r["count"] == SCENE_COUNT and len(r["seeds"]) >= 2]
    presets = {}
    for name, rule in PRESET_RULES.items():
        best = cheapest_within(candidates, rule["stress"], score_key="score_stress",
                               also=lambda r, rule=rule: meets(r, rule))
        if best is not None and ref_row is not None:
            steps_paper = round(0.10 / PAPER_INC)
            steps_preset = round(0.10 / best["strain_increment"])
            # Its own preparation would run with its time step and servo cap; where no sample prepared so was
            # shown to meet the rule, the preset starts from the paper's prepared sample, as the study's runs did.
            own = preparation_ok(rows, best["time_step"], best["servo_max_strain_increment"], rule)
            presets[name] = {"row": best["key"], "label": best["label"], "rule": rule["text"],
                             "preparation": "own" if own else "paper",
                             "time_step": best["time_step"], "dt_over_tc": best["dt_over_tc"],
                             "strain_increment": best["strain_increment"],
                             "servo_max_strain_increment": best["servo_max_strain_increment"],
                             "output_interval": best["output_interval"],
                             "inertial_number": best["inertial_number"], "score": best["score"],
                             "score_stress": best["score_stress"], "score_volume": best["score_volume"],
                             "seeds": best["seeds"], "errors": best["errors"],
                             "test_steps_speedup": steps_paper / steps_preset,
                             "measured_speedup": (ref_row["cost"] / best["cost"]) if best["cost"] else None}

    # Modelling choices.
    modelling = []
    for key in ("project", "radius", "rotdamp0", "lammps"):
        per_seed, label = [], None
        for n, e in ok.items():
            s = e["spec"]
            if s.get("role") == "modelling" and s.get("value") == key and s["seed"] in refs:
                label = s["label"]
                per_seed.append(errors_against(e["metrics"], refs[s["seed"]]["metrics"], floor, MODELLING_QUANTITIES))
        if per_seed:
            # Signed mean over seeds: a modelling choice shifts a quantity one way.
            entry = {"key": key, "label": label, "seeds": len(per_seed)}
            for q in MODELLING_QUANTITIES:
                errs = [p[q][0] for p in per_seed if q in p]
                if errs:
                    m = float(np.mean(errs))
                    entry[f"{q[0]}.{q[1]}"] = [m, abs(m) / floor[q] if floor.get(q) else None]
            modelling.append(entry)

    stability = analyse_stability(ok, results, paper, floor, d_mean)
    limits = thresholds(rows, cap_rows, stability)
    samples = {n: {"spec": e["spec"], "prepared": e["summary"].get("prepared"), "outcome_rc": e["outcome"].get("rc"),
                   "cpu_s": e["outcome"].get("cpu_s")}
               for n, e in results.items() if e["spec"].get("kind") == "sample"}
    hosts = sorted({e["outcome"].get("host") for e in results.values() if e["outcome"].get("host")})
    peaks = {f"{t}": [refs[s]["metrics"].get(t, {}).get("e1_peak") for s in sorted(refs)] for t in ("ttc", "psc")}
    return {"scene": {"count": SCENE_COUNT, "end_strain": END_STRAIN, "t_c": tc, "d_mean": d_mean, "density": rho,
                      "p": P_REF, "paper_dt_over_tc": PAPER_DT / tc,
                      "paper_inertial_number": inertial_number(PAPER_RATE, d_mean, rho),
                      "reference_seeds": sorted(refs), "hosts": hosts, "reference_e1_at_peak": peaks},
            "noise_floor": {f"{t}.{q}": [mean[(t, q)], floor[(t, q)]] for t, q in QUANTITIES},
            "binaries": read_json(os.path.join(root, "binaries.json")) or [],
            "thresholds": limits, "rows": rows, "servo_cap_rows": cap_rows, "presets": presets,
            "modelling": modelling, "stability": stability, "samples": samples}


def thresholds(rows, cap_rows, stability):
    """Where the scheme leaves its working range, from the measurements: the numbers behind run-time detection."""
    out = {}
    st = [r for r in stability["dt"] if r["damping"] == PAPER_DAMPING and r.get("state") != "failed"]
    ok_dt = [r["dt_over_tc"] for r in st if r["state"] == "stable"]
    bad_dt = [r["dt_over_tc"] for r in st if r["state"] in ("unstable", "blow-up")]
    out["dt_stable_max"] = max(ok_dt) if ok_dt else None
    out["dt_drift"] = sorted(r["dt_over_tc"] for r in st if r["state"] == "drift")
    out["dt_unstable_min"] = min(bad_dt) if bad_dt else None
    all_dt = [r for r in stability["dt"] if r.get("ke_max") is not None]
    out["ke_stable_max"] = max((r["ke_max"] for r in all_dt if r["state"] in ("stable", "drift")), default=None)
    out["ke_unstable_min"] = min((r["ke_max"] for r in all_dt if r["state"] == "unstable"), default=None)
    # Loading rate: settings at a stable time step, by inertial number.
    stable_rows = [r for r in rows if r["dt_over_tc"] <= 0.5 and r["group"] in
                   ("reference", "null", "strain_increment", "time_step", "density", "combined")
                   and r.get("score_stress") is not None]
    ok_i = [r["inertial_number"] for r in stable_rows if r["score_stress"] <= 1.0]
    bad_i = [r["inertial_number"] for r in stable_rows if r["score_stress"] > 1.0]
    out["I_stress_ok_max"] = max(ok_i) if ok_i else None
    out["I_stress_bad_min"] = min(bad_i) if bad_i else None
    ok_v = [r["inertial_number"] for r in stable_rows if r["score_volume"] is not None and r["score_volume"] <= 2.0]
    out["I_volume_ok_max"] = max(ok_v) if ok_v else None
    out["ke_quasi_static_max"] = max((r["ke_max"] for r in stable_rows if r.get("ke_max") is not None
                                      and r["score_stress"] <= 1.0), default=None)
    # Servo: the cap on the strain per step, and the gains.
    capped = [(r["strain_increment"] / r["servo_max_strain_increment"], r["servo_max_error"]) for r in cap_rows
              if r.get("servo_max_error") is not None]
    out["cap_ratio_ok_max"] = max((x for x, e in capped if e <= SERVO_TOLERANCE), default=None)
    out["cap_ratio_bad_min"] = min((x for x, e in capped if e > SERVO_TOLERANCE), default=None)
    out["servo_max_error_reference"] = max((r["servo_max_error"] for r in rows if r["group"] == "reference"
                                            and r.get("servo_max_error") is not None), default=None)
    servo = [r for r in stability["servo"] if r.get("std") is not None]
    out["servo_failing"] = [[r["gain"], r["integral_gain"], r["std"], r["bias"]] for r in servo if not r["holds"]]
    out["servo_std_max_holding"] = max((r["std"] for r in servo if r["holds"]), default=None)
    return out


def analyse_stability(ok, results, paper, floor, d_mean):
    """Time step × damping, servo gains, and error against the inertial number."""
    out = {"dt": [], "servo": []}
    stab = {n: e for n, e in results.items() if e["spec"].get("group") == "stability_dt"}
    # The baseline of each damping value: its run at the paper's time step.
    base = {}
    for n, e in stab.items():
        s = e["spec"]
        if abs(s["time_step"] - PAPER_DT) < 1e-12 and e["outcome"].get("rc") == 0 and "ttc" in e["series"]:
            base[s["damping"][0]] = e
    mean_d3 = float(np.mean(np.array(diameters_of(paper)) ** 3))
    for n, e in sorted(stab.items(), key=lambda kv: (kv[1]["spec"]["damping"][0], kv[1]["spec"]["time_step"])):
        s = e["spec"]
        row = {"name": n, "dt_over_tc": s["value"], "damping": s["damping"][0], "rc": e["outcome"].get("rc")}
        series = e["series"].get("ttc")
        if e["outcome"].get("rc") != 0 or series is None:
            row.update(state="failed", message=(e["outcome"].get("log_tail") or "").strip().splitlines()[-1:]
                       if e["outcome"].get("log_tail") else [])
            out["dt"].append(row)
            continue
        finite = test_metrics(series, s["end_strain"])["finite"]
        ke_rel = kinetic_ratio(series, s["count"], mean_d3)
        if ke_rel is not None and np.all(np.isfinite(ke_rel)):
            row["ke_max"] = float(np.max(ke_rel[1:])) if ke_rel.size > 1 else float(ke_rel[0])
        else:
            row["ke_max"] = math.inf
        b = base.get(s["damping"][0])
        if b is not None and b is not e:
            bs = b["series"]["ttc"]
            dev = []
            for col in ("ratio13", "ev"):
                diff, _ = cr.curve_difference(series["e1"], series[col], bs["e1"], bs[col], bins=20,
                                              relative_to="range")
                dev.append(diff)
            # Drift of σ1/σ3 at the end of the run (mean over its last fifth), against the TTC peak's noise floor.
            end = min(s["end_strain"], float(np.nanmax(series["e1"])), float(np.nanmax(bs["e1"])))

            def tail_mean(x, y):
                keep = (x >= 0.8 * end) & (x <= end) & np.isfinite(y)
                return float(np.mean(y[keep])) if np.any(keep) else None

            end_r, end_b = tail_mean(series["e1"], series["ratio13"]), tail_mean(bs["e1"], bs["ratio13"])
            f = floor.get(("ttc", "peak_ratio"))
            row["ratio_drift"] = abs(end_r - end_b) / f if end_r is not None and end_b is not None and f else None
            row["curve_diff_ratio"], row["curve_diff_ev"] = dev
        drift = row.get("ratio_drift") is not None and row["ratio_drift"] > DRIFT_FLOORS
        row["state"] = ("blow-up" if not finite else "unstable" if row["ke_max"] > KE_UNSTABLE
                        else "drift" if drift else "stable")
        out["dt"].append(row)
    for n, e in sorted(results.items()):
        s = e["spec"]
        if s.get("group") != "stability_servo":
            continue
        row = {"name": n, "gain": s["servo"]["gain"], "integral_gain": s["servo"]["integral_gain"],
               "rc": e["outcome"].get("rc")}
        series = e["series"].get("ttc")
        if e["outcome"].get("rc") == 0 and series is not None:
            row["std"], row["bias"], row["max"] = servo_error_stats(series, {"s22": P_REF, "s33": P_REF})
            row["peak_ratio"] = test_metrics(series, s["end_strain"])["peak_ratio"]
            row["holds"] = row["std"] is not None and row["std"] <= SERVO_TOLERANCE and row["bias"] <= SERVO_TOLERANCE
        out["servo"].append(row)
    return out


# ---- analysis: the charts and the report ------------------------------------------------------------------------

GROUP_STYLE = {
    "reference": ("k", "*", "reference (paper settings)"),
    "null": ("0.4", "p", "round-off only (dt × (1 + 1e-9))"),
    "strain_increment": ("C0", "o", "strain increment per step"),
    "time_step": ("C1", "s", "time step (at the paper's rate)"),
    "density": ("C2", "^", "density scaling"),
    "combined": ("C3", "D", "larger dt and rate together"),
    "damping": ("C4", "v", "damping fraction"),
    "output_interval": ("C5", "P", "output interval"),
    "count": ("C6", "X", "particle count"),
    "prepare_dt": ("C7", "h", "sample prepared at larger dt"),
}


def draw_charts(study, fig_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(fig_dir, exist_ok=True)
    paths = {}
    rows = [r for r in study["rows"] if r["cost"] is not None and r["score"] is not None]
    floor_y = 1e-2

    # 1. Error against cost, with the Pareto front and the inertial number of each point: all quantities, and the
    #    stress-ratio quantities alone.
    fig, axes = plt.subplots(1, 2, figsize=(16, 7), sharex=True)
    preset_keys = {p["row"]: name for name, p in study["presets"].items()}
    null = next((r for r in rows if r["group"] == "null"), None)
    for ax, key, title in ((axes[0], "score", "all compared quantities"),
                           (axes[1], "score_stress", "stress-ratio quantities: peak σ1/σ3, ε1 at peak, b")):
        seen = set()
        panel = [r for r in rows if r.get(key) is not None]
        ys = [min(max(r[key], floor_y), 1e3) for r in panel]
        front = set(pareto_front([(r["cost"], y) for r, y in zip(panel, ys)]))
        for i, (r, y) in enumerate(zip(panel, ys)):
            color, marker, label = GROUP_STYLE.get(r["group"], ("0.5", "o", r["group"]))
            ax.scatter(r["cost"], y, color=color, marker=marker, s=60 if i in front else 35,
                       edgecolor="k" if i in front else "none", label=None if r["group"] in seen else label, zorder=3)
            seen.add(r["group"])
            ax.annotate(f"I={r['inertial_number']:.1e}", (r["cost"], y), textcoords="offset points", xytext=(4, 3),
                        fontsize=6.5, color=color)
            if r["key"] in preset_keys:
                ax.scatter(r["cost"], y, s=260, facecolor="none", edgecolor="m", linewidth=1.5, zorder=4)
                ax.annotate(preset_keys[r["key"]], (r["cost"], y), textcoords="offset points", xytext=(-10, -16),
                            fontsize=8, color="m")
        pts = sorted((panel[i]["cost"], ys[i]) for i in front)
        if pts:
            ax.step([c for c, _ in pts], [y for _, y in pts], where="post", color="k", linewidth=1, linestyle="--",
                    label="Pareto front", zorder=2)
        ax.axhline(1.0, color="r", linewidth=1, label="noise floor (seed-to-seed std)")
        if null is not None and null.get(key) is not None:
            ax.axhline(null[key], color="0.4", linewidth=0.8, linestyle=":",
                       label="round-off only: what an exact setting scores")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"run time of the tests to ε1 = {END_STRAIN:.0%}, {SCENE_COUNT} spheres (single-thread CPU s)")
        ax.set_ylabel("largest |error| / noise floor (–)")
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend(fontsize=7.5, loc="lower left")
    fig.suptitle("celldem speed against accuracy on the reduced scene (error: mean over seeds of the paired "
                 "difference from the reference; reference drawn at 0.01; magenta rings: presets)", fontsize=10)
    fig.tight_layout()
    paths["pareto"] = os.path.join(fig_dir, "pareto.png")
    fig.savefig(paths["pareto"], dpi=120)
    plt.close(fig)

    # 2. The stability map.
    st = study["stability"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 9.5))
    ax = axes[0, 0]
    colors = {"stable": "tab:green", "drift": "tab:orange", "unstable": "tab:red", "blow-up": "darkred",
              "failed": "k"}
    for state, color in colors.items():
        pts = [r for r in st["dt"] if r["state"] == state]
        if pts:
            ax.scatter([r["dt_over_tc"] for r in pts], [r["damping"] for r in pts], color=color, s=90, label=state,
                       marker="x" if state == "failed" else "o")
    for r in st["dt"]:
        txt = "fail" if r["state"] == "failed" else f"KE {r.get('ke_max', math.nan):.0e}"
        ax.annotate(txt, (r["dt_over_tc"], r["damping"]), textcoords="offset points", rotation=60,
                    xytext=(-4, 8), fontsize=6)
    ax.set_xlabel("time step / sqrt(m_min/kn) (–)")
    ax.set_ylabel("damping fraction (–)")
    ax.set_ylim(-0.006, 0.064)
    ax.set_title(f"time step × damping (TTC to ε1 = {STABILITY_STRAIN:.0%}, paper's rate)\n"
                 "KE: max kinetic energy / (p V)", fontsize=10)
    ax.legend(fontsize=8, loc="center right")
    ax.grid(True, alpha=0.3)

    ax = axes[0, 1]
    rate_rows = [r for r in study["rows"] if r["group"] in ("reference", "strain_increment", "time_step", "density",
                                                             "combined") and r["score"] is not None
                 and r["dt_over_tc"] <= 0.5]
    for r in rate_rows:
        color, marker, _ = GROUP_STYLE.get(r["group"], ("0.5", "o", ""))
        ax.scatter(r["inertial_number"], min(max(r["score"], floor_y), 1e3), color=color, marker=marker)
    ax.axhline(1.0, color="r", linewidth=1)
    ax.axvline(QUASI_STATIC_I, color="0.4", linestyle="--", linewidth=1)
    ax.text(QUASI_STATIC_I, ax.get_ylim()[1] if ax.get_ylim()[1] < 1e3 else 1e2, " I = 1e-3", fontsize=8, va="top")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("inertial number I = ε̇ d sqrt(ρ/p) (–)")
    ax.set_ylabel("largest error / noise floor (–)")
    ax.set_title("loading rate against the quasi-static limit\n(settings with dt ≤ 0.5 t_c)", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)

    ax = axes[1, 0]
    servo = [r for r in st["servo"] if r.get("std") is not None]
    if servo:
        gains = sorted({r["gain"] for r in st["servo"]})
        igains = sorted({r["integral_gain"] for r in st["servo"]})
        grid = np.full((len(igains), len(gains)), np.nan)
        for r in servo:
            grid[igains.index(r["integral_gain"]), gains.index(r["gain"])] = r["std"] * 100
        im = ax.imshow(np.log10(np.clip(grid, 1e-3, None)), origin="lower", cmap="viridis", aspect="auto")
        for r in st["servo"]:
            i, j = igains.index(r["integral_gain"]), gains.index(r["gain"])
            txt = "fail" if r.get("std") is None else (f"{r['std'] * 100:.2g}%" + (
                f"\nbias {r['bias'] * 100:.2g}%" if r["bias"] > 1e-4 else "") + ("" if r.get("holds") else " ✗"))
            ax.text(j, i, txt, ha="center", va="center", fontsize=7, color="w")
        ax.set_xticks(range(len(gains)), [f"{g:g}" for g in gains])
        ax.set_yticks(range(len(igains)), [f"{g:g}" for g in igains])
        fig.colorbar(im, ax=ax, label="log10(std of σ22, σ33 error, %)")
    ax.set_xlabel("servo gain (–)")
    ax.set_ylabel("servo integral_gain (–)")
    ax.set_title(f"servo: std of (σ/100 kPa − 1) of x2, x3; ✗: std or bias above {SERVO_TOLERANCE:.1%}")

    ax = axes[1, 1]
    for alpha in sorted({r["damping"] for r in st["dt"]}):
        pts = sorted((r for r in st["dt"] if r["damping"] == alpha and r.get("ke_max") is not None),
                     key=lambda r: r["dt_over_tc"])
        if pts:
            ax.plot([r["dt_over_tc"] for r in pts], [min(max(r["ke_max"], 1e-12), 1e6) for r in pts], "o-",
                    label=f"damping {alpha:g}")
    ax.axhline(KE_UNSTABLE, color="r", linewidth=1, label="unstable above")
    ax.set_yscale("log")
    ax.set_xlabel("time step / sqrt(m_min/kn) (–)")
    ax.set_ylabel("max kinetic energy / (p V) (–)")
    ax.set_title("kinetic energy against time step, per damping")
    ax.legend(fontsize=8)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    paths["stability"] = os.path.join(fig_dir, "stability.png")
    fig.savefig(paths["stability"], dpi=120)
    plt.close(fig)
    return paths


def draw_reference_curves(results, fig_dir):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    refs = sorted((e for e in results.values() if e["spec"].get("role") == "reference"
                   and e["outcome"].get("rc") == 0), key=lambda e: e["spec"]["seed"])
    if not refs:
        return None
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for e in refs:
        for k, test in enumerate(("ttc", "psc")):
            s = e["series"].get(test)
            if s is None:
                continue
            style = dict(color=f"C{e['spec']['seed'] - 1}", linestyle="-" if test == "ttc" else "--", linewidth=1)
            axes[0].plot(s["e1"] * 100, s["ratio13"], label=f"{test} seed {e['spec']['seed']}", **style)
            axes[1].plot(s["e1"] * 100, s["ev"] * 100, **style)
            axes[2].plot(s["e1"] * 100, s["Z"], **style)
    for ax, label in zip(axes, ("σ1/σ3 (–)", "εv (%)", "Z (–)")):
        ax.set_xlabel("ε1 (%)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"reference runs: paper settings, {SCENE_COUNT} spheres, four seeds (TTC solid, PSC dashed)")
    fig.tight_layout()
    path = os.path.join(fig_dir, "reference.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


PERCENT_QUANTITIES = ("e1_peak", "ev_end")


def scaled(value, quantity):
    """A strain quantity in %, others as they are."""
    return None if value is None else value * (100.0 if quantity in PERCENT_QUANTITIES else 1.0)


def md_table(headers, rows):
    lines = ["| " + " | ".join(str(h).replace("|", "\\|") for h in headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    lines += ["| " + " | ".join(str(c).replace("|", "\\|") for c in row) + " |" for row in rows]
    return "\n".join(lines)


def err_cell(errors, key, scale=1.0):
    v = errors.get(key)
    if v is None:
        return "n/a"
    e, n = v
    mark = "" if n is None or n <= 1.0 else " ✗"
    return f"{fmt(e * scale)} ({fmt(n, 2)}){mark}"


def write_markdown(study, root, fig_paths, ref_fig):
    sc = study["scene"]
    floor = study["noise_floor"]
    out = ["# celldem speed–accuracy and stability study",
           "",
           f"Reduced scene: **{sc['count']} spheres** (the paper's sizes, density, contact law, damping and "
           f"preparation; sample.count changed only), tests to **ε1 = {sc['end_strain']:.0%}** (the paper: 8000 "
           f"spheres to 10 %). εv and Z \"at the end\" are their means over ε1 = "
           f"{(sc['end_strain'] - END_WINDOW) * 100:g}–{sc['end_strain'] * 100:g} % (the issue's 5 % is beyond the "
           f"reduced tests' end). Critical step "
           f"t_c = sqrt(m_min/kn) = {sc['t_c']:.3e} s; the paper's dt = 1e-6 s is {sc['paper_dt_over_tc']:.3f} t_c; "
           f"its inertial number I = ε̇·d·sqrt(ρ/p) = {sc['paper_inertial_number']:.2e} (d = {sc['d_mean'] * 1e3:.3g} mm "
           f"mean diameter, p = 100 kPa). Run times are single-thread CPU seconds (celldem --threads 1), one run "
           f"at a time, on {', '.join(sc['hosts']) or 'n/a'}; wall times are in study.json.",
           "",
           "celldem binaries used: " + ("; ".join(f"`{b.get('path')}` sha256 {str(b.get('sha256'))[:12]}…, built "
                                                  f"{b.get('built')}" + (f" ({b['note']})" if b.get("note") else "")
                                                  for b in study.get("binaries") or []) or "n/a") + ".",
           "",
           f"Reference ε1 at peak σ1/σ3 per seed: TTC {', '.join(fmt(x * 100 if x is not None else None, 2) for x in sc['reference_e1_at_peak']['ttc'])} %, "
           f"PSC {', '.join(fmt(x * 100 if x is not None else None, 2) for x in sc['reference_e1_at_peak']['psc'])} %: "
           f"the peak lies well inside ε1 = {sc['end_strain']:.0%}.",
           "",
           "## Noise floor",
           "",
           f"Mean and seed-to-seed standard deviation over the reference samples (seeds "
           f"{', '.join(str(s) for s in sc['reference_seeds'])}, paper settings). An error below the standard "
           f"deviation is not an error.",
           "",
           md_table(("quantity", "mean", "std (noise floor)"),
                    [(f"{t.upper()} {QUANTITY_LABELS[q]}" + (" (%)" if q in PERCENT_QUANTITIES else ""),
                      fmt(scaled(floor[f'{t}.{q}'][0], q)), fmt(scaled(floor[f'{t}.{q}'][1], q)))
                     for t, q in QUANTITIES]),
           "",
           "## Speed against accuracy",
           "",
           f"![error against run time]({os.path.relpath(fig_paths['pareto'], root)})",
           "",
           "Each setting changes one knob from the paper's settings (\"combined\": dt and rate together). Errors are "
           "differences from the reference on the same sample (mean over the seeds run), in parentheses divided by "
           "the noise floor; ✗ marks a quantity outside the floor. Score: the largest normalised error. "
           "Particle count runs are different samples, compared with the reference mean.",
           "",
           ]
    headers = ("setting", "seeds", "dt/t_c", "Δε1/step", "I", "CPU s", "wall s", "score", "Pareto",
               "TTC peak σ1/σ3", "TTC ε1 peak (%)", "TTC εv end (%)", "TTC Z end", "PSC peak σ1/σ3",
               "PSC ε1 peak (%)", "PSC εv end (%)", "PSC Z end", "PSC b peak")
    table = []
    for r in study["rows"]:
        e = r["errors"]
        table.append((r["label"], ",".join(str(s) for s in r["seeds"]) + (f" ({r['failed']} failed)" if r["failed"] else ""),
                      fmt(r["dt_over_tc"], 3), fmt(r["strain_increment"]), fmt(r["inertial_number"]),
                      fmt(r["cost"], 1), fmt(r["wall"], 1), fmt(r["score"], 2), "yes" if r["pareto"] else "",
                      err_cell(e, "ttc.peak_ratio"), err_cell(e, "ttc.e1_peak", 100), err_cell(e, "ttc.ev_end", 100),
                      err_cell(e, "ttc.Z_end"), err_cell(e, "psc.peak_ratio"), err_cell(e, "psc.e1_peak", 100),
                      err_cell(e, "psc.ev_end", 100), err_cell(e, "psc.Z_end"), err_cell(e, "psc.b_peak")))
    out += [md_table(headers, table), ""]
    out += ["Run-time health of the same settings: the largest kinetic energy / (p V) after the first row (V from "
            "the void ratio and the mean sphere volume), and the largest relative error of a stress-controlled axis "
            "that celldem reports (summary.json servo_max_error, rows after the first 2 %), against the score.", ""]
    out += [md_table(("setting", "I", "dt/t_c", "max KE/(pV)", "servo max error (%)", "score"),
                     [(r["label"], fmt(r["inertial_number"]), fmt(r["dt_over_tc"], 3), fmt(r.get("ke_max")),
                       fmt(r.get("servo_max_error") and r["servo_max_error"] * 100), fmt(r["score"], 2))
                      for r in study["rows"]]), ""]

    out += ["## Presets", ""]
    if study["presets"]:
        prow = []
        for name, p in study["presets"].items():
            prow.append((f"inputs/{name}.json", p["rule"], p["label"], p["preparation"],
                         ",".join(str(x) for x in p["seeds"]),
                         fmt(p["time_step"]), fmt(p["dt_over_tc"], 3), fmt(p["strain_increment"]),
                         fmt(p["servo_max_strain_increment"]), fmt(p["inertial_number"]), fmt(p["score_stress"], 2),
                         fmt(p["score_volume"], 2), f"{p['test_steps_speedup']:.1f}×",
                         f"{p['measured_speedup']:.1f}×" if p.get("measured_speedup") else "n/a"))
        out += [md_table(("preset", "rule", "setting", "preparation", "seeds", "time_step (s)", "dt/t_c", "Δε1/step",
                          "servo.max_strain_increment", "I", "stress-ratio errors / floor (max)",
                          "εv, Z errors / floor (max)", "speed-up of the tests (steps)",
                          "measured speed-up (reduced scene, CPU)"), prow),
                "",
                "A preset is the cheapest setting, run on at least two seeds, whose errors meet its rule; it is written "
                "as the paper deck (8000 spheres, ε1 to 10 %) with only time_step, the axial strain increment, the "
                "servo's cap on the strain per step (5 × Δε1, the paper's own ratio) and the output interval (a row "
                "every 2e-4 of ε1, as the paper deck) changed. inputs/paper.json remains paper fidelity. The deck's "
                "time step and servo cap also apply to its preparation; samples prepared with a larger dt or cap and "
                "then run with the paper's tests (below) differ from the reference by more than the noise floor "
                "(the TTC peak drops by about 0.1 in all four samples prepared with a larger cap), so such a preset "
                "starts from the paper deck's prepared sample (\"initial_state\", column preparation = paper), "
                "exactly as the study's runs did:", ""]
        for r in study["rows"]:
            if r["group"] == "prepare_dt":
                out += [f"- {r['label']} (seeds {','.join(str(x) for x in r['seeds'])}), then the paper's tests: "
                        f"stress-ratio errors {fmt(r['score_stress'], 2)} floors, εv and Z {fmt(r['score_volume'], 2)} "
                        "floors against the reference mean (a different packing, so unpaired)."]
        out += [""]
    else:
        out += ["No setting meets a preset's rule (or no reference yet).", ""]

    out += ["## Samples", ""]
    srows = []
    for n, s in sorted(study["samples"].items()):
        p = s.get("prepared") or {}
        srows.append((n, s["spec"]["label"], fmt(p.get("void_ratio")), fmt(p.get("Z"), 3), fmt(p.get("steps")),
                      fmt(s.get("cpu_s"), 1), "ok" if s["outcome_rc"] == 0 else f"rc {s['outcome_rc']}"))
    out += [md_table(("sample", "what", "void ratio e", "Z", "preparation steps", "CPU s", "state"), srows), ""]

    out += ["## Stability map", "", f"![stability map]({os.path.relpath(fig_paths['stability'], root)})", "",
            f"Time step × damping: TTC from the seed-1 sample to ε1 = {STABILITY_STRAIN:.0%} at the paper's strain "
            "rate 0.2/s. blow-up: non-finite values; unstable: max kinetic energy above "
            f"{KE_UNSTABLE:g} p·V (quasi-static runs stay near 1e-6 p·V); drift: σ1/σ3 over the last "
            f"fifth of the run differs from the same damping's run at the paper's dt by more than {DRIFT_FLOORS:g} TTC "
            "peak noise floors (round-off alone moves it by about one).", ""]
    drows = [(fmt(r["dt_over_tc"], 3), fmt(r["damping"]), r["state"], fmt(r.get("ke_max")),
              fmt(r.get("ratio_drift"), 2), fmt(r.get("curve_diff_ratio")), fmt(r.get("curve_diff_ev")))
             for r in study["stability"]["dt"]]
    out += [md_table(("dt/t_c", "damping", "state", "max KE/(pV)", "σ1/σ3 drift / floor",
                      "σ1/σ3 curve diff / range", "εv curve diff / range"), drows), ""]
    out += ["Servo cap: the first pass of the strain-increment, time-step, density and combined settings, run with "
            "celldem's default servo.max_strain_increment = 1e-6 (the stress servo moves an axis by at most that "
            "much per step). PSC's free axis dilates at about 2 × Δε1 per step, so once Δε1 exceeds about half the "
            "cap the servo cannot follow and σ3 runs away; errors: the largest relative error of a stress-controlled "
            "axis that celldem reports (summary.json servo_max_error).", ""]
    crow = [(r["label"], fmt(r["strain_increment"]), fmt(r["strain_increment"] / r["servo_max_strain_increment"], 2),
             fmt(r["inertial_number"]), fmt((r["servo_max_error_by_test"].get("ttc") or 0) * 100, 3),
             fmt((r["servo_max_error_by_test"].get("psc") or 0) * 100, 3), fmt(r["score"], 2))
            for r in sorted(study.get("servo_cap_rows", []), key=lambda r: r["strain_increment"])]
    out += [md_table(("setting", "Δε1/step", "Δε1 / cap", "I", "TTC servo max error (%)", "PSC servo max error (%)",
                      "score"), crow), ""]
    out += [f"Servo gains: TTC to ε1 = {SERVO_STRAIN:.1%} at Δε1 = {SERVO_INC:g}/step (I = "
            f"{inertial_number(SERVO_INC / PAPER_DT, sc['d_mean'], sc['density']):.1e}), a row every "
            f"{SERVO_OUTPUT_INTERVAL} steps; error of σ22 and σ33 against 100 kPa after the first 10 % of rows.", ""]
    srows = [(fmt(r["gain"]), fmt(r["integral_gain"]), fmt(r.get("std") and r["std"] * 100, 3),
              fmt(r.get("bias") and r["bias"] * 100, 3), fmt(r.get("max") and r["max"] * 100, 3),
              fmt(r.get("peak_ratio")), "yes" if r.get("holds") else ("no" if r.get("rc") == 0 else f"rc {r.get('rc')}"))
             for r in study["stability"]["servo"]]
    out += [md_table(("gain", "integral_gain", "error std (%)", "|mean error| (%)", "max error (%)", "TTC peak σ1/σ3",
                      "holds (std and bias ≤ 0.5 %)"), srows), ""]

    t = study.get("thresholds") or {}
    out += ["## Where the scheme fails: thresholds for run-time detection", "",
            md_table(("what", "measured"), [
                ("time step (damping 0.05; damping 0, 0.01 alike)",
                 f"results unchanged up to dt = {fmt(t.get('dt_stable_max'), 2)} t_c; σ1/σ3 drifts at "
                 f"{', '.join(fmt(x, 2) for x in t.get('dt_drift') or []) or 'none'} t_c; unstable from "
                 f"{fmt(t.get('dt_unstable_min'), 2)} t_c (finite, but the kinetic energy is 100 times the "
                 "quasi-static level and the results are wrong)"),
                ("kinetic energy / (p V)",
                 f"quasi-static settings ≤ {fmt(t.get('ke_quasi_static_max'))}; short stable runs ≤ "
                 f"{fmt(t.get('ke_stable_max'))}; unstable runs ≥ {fmt(t.get('ke_unstable_min'))}"),
                ("inertial number I (dt ≤ 0.5 t_c)",
                 f"stress-ratio results inside the noise floor up to I = {fmt(t.get('I_stress_ok_max'))}, outside from "
                 f"{fmt(t.get('I_stress_bad_min'))}; εv and Z within 2 floors up to I = {fmt(t.get('I_volume_ok_max'))}"),
                ("servo cap: Δε1 / servo.max_strain_increment",
                 f"the servo holds (max error ≤ 0.5 %) up to {fmt(t.get('cap_ratio_ok_max'), 2)}, fails from "
                 f"{fmt(t.get('cap_ratio_bad_min'), 2)}; the paper's settings: max error "
                 f"{fmt((t.get('servo_max_error_reference') or 0) * 100, 3)} %"),
                ("servo gains (gain ≤ 1 by deck validation)",
                 "no oscillation at any gain; failing (std or bias > 0.5 %): " + (", ".join(
                     f"gain {g:g} / integral {i:g} (bias {b * 100:.2g} %)" for g, i, _, b in t.get("servo_failing", []))
                     or "none") + f"; holding settings: error std ≤ {fmt((t.get('servo_std_max_holding') or 0) * 100, 3)} %"),
            ]), ""]

    out += ["## Modelling choices", "",
            "The reduced TTC with one modelling choice changed, against the reference on the same samples (mean "
            "signed difference over the seeds run; in parentheses divided by the noise floor; ✗: outside it).", ""]
    mrows = []
    for m in study["modelling"]:
        cells = []
        for t, q in MODELLING_QUANTITIES:
            v = m.get(f"{t}.{q}")
            scale = 100 if q == "ev_end" else 1
            cells.append("n/a" if v is None else f"{fmt(v[0] * scale)} ({fmt(v[1], 2)})" + (" ✗" if v[1] and v[1] > 1 else ""))
        changes = [QUANTITY_LABELS[q] for (t, q) in MODELLING_QUANTITIES
                   if m.get(f"{t}.{q}") and m[f"{t}.{q}"][1] and m[f"{t}.{q}"][1] > 1]
        mrows.append((m["label"], m["seeds"], *cells, ", ".join(changes) or "none beyond the noise floor"))
    out += [md_table(("choice (paper: rotate, contact_point, rot. damping 0.05, affine)", "seeds",
                      "Δ peak σ1/σ3", "Δ εv at end (%)", "Δ Z at end", "changes"), mrows), ""]
    if ref_fig:
        out += ["## Reference curves", "", f"![reference]({os.path.relpath(ref_fig, root)})", ""]
    path = os.path.join(root, "study.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out))
    return path


def jsonable(x):
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, float) and not math.isfinite(x):
        return None if math.isnan(x) else ("inf" if x > 0 else "-inf")
    if isinstance(x, (np.floating,)):
        return jsonable(float(x))
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
