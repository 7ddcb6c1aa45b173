"""The analysis half of tools/study.py: the compared quantities, the noise floor, the errors, the Pareto front,
the presets' choice, the stability measures.

Everything here is a function of the run folders under the study root (spec.json, outcome.json, plan.json,
summary.json, <test>/series.csv), so tests/tools/test_study_analysis.py can check it on synthetic results without
running celldem. The compared quantities are summary.json's; what a deck implies is plan.json's.
"""

import math
import os

import numpy as np

from .. import binary
from ..metrics import all_finite, curve_difference
from ..results import RunError, load_series, number, read_json
from .scene import (END_STRAIN, KE_UNSTABLE, DRIFT_FLOORS, MODELLING_QUANTITIES, P_REF, PAPER_DAMPING,
                          PAPER_DT, PRESET_RULES, QUANTITIES, SCENE_COUNT, SERVO_STD_LIMIT, STRESS_QUANTITIES,
                          SUMMARY_KEYS, servo_tolerance)

# ---- analysis: pure functions of run metrics (tested by tests/tools/test_study_analysis.py) ---------------------------

def test_metrics(summary_test, end_strain):
    """The compared quantities of one test, from its entry in summary.json (celldem's definitions, SUMMARY_KEYS);
    None where not measurable. The end values only when the run reached the end strain (up to the rounding of its
    steps): end_window is the last 0.5 % of the run's ε1, which is then the window before END_STRAIN."""
    def value(path):
        v = summary_test
        for part in path.split("."):
            v = v.get(part) if isinstance(v, dict) else None
        return number(v)

    out = {name: value(key) for name, key in SUMMARY_KEYS.items()}
    out["e1_final"] = value("final_e1")
    if out["e1_final"] is None or out["e1_final"] < end_strain * (1 - 1e-3):
        out["ev_end"] = out["Z_end"] = None
    return out


def kinetic_ratio(series, solid_volume):
    """Kinetic energy / (p V) per row, V = the spheres' volume (plan.json) × (1 + e); None without the columns."""
    ke, void = series.get("kinetic_energy"), series.get("void_ratio")
    if ke is None or void is None or solid_volume is None:
        return None
    return ke / (P_REF * solid_volume * (1.0 + void))


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


def preparation_ok(rows, time_step, servo_cap, rule, paper_servo_cap):
    """A preset's deck prepares its sample with its own time step and servo cap: fine with the paper's (time step
    PAPER_DT, cap `paper_servo_cap`, the reference runs' summary.json setting), else only where a sample prepared
    with those, run with the paper's tests, meets the same rule (unknown is not fine)."""
    def same(a, b):
        return a is not None and b is not None and abs(a - b) <= 1e-9 * max(abs(a), abs(b))
    if same(time_step, PAPER_DT) and same(servo_cap, paper_servo_cap):
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
    """spec name -> {"spec", "outcome", "summary", "plan", "series" (test -> columns), "metrics" (test -> quantities
    from summary.json, and "finite": whether the series stayed finite)}. plan is plan.json (None without it)."""
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
                     "plan": read_json(os.path.join(d, "plan.json")), "series": {}, "metrics": {}, "dir": d}
            for test in spec.get("tests", []):
                path = os.path.join(d, test, "series.csv")
                if os.path.isfile(path):
                    try:
                        entry["series"][test] = load_series(path)
                    except RunError:
                        continue
                    info = (entry["summary"].get("tests") or {}).get(test) or {}
                    entry["metrics"][test] = dict(test_metrics(info, spec["end_strain"]),
                                                  finite=all_finite(entry["series"][test]))
            results[name] = entry
    return results


def setting(entry, key):
    """A value of the run's summary.json settings (servo_max_strain_increment, time_step), or None."""
    return number((entry.get("summary", {}).get("settings") or {}).get(key))


def planned(entry, key, test=None):
    """A number of the run's plan.json: top level (time_step_ratio, critical_time_step), of its first (or named)
    test (steps, strain_rate, inertial_number), or of its sample (mean_diameter, density); None without a plan."""
    plan = entry.get("plan")
    if not plan:
        return None
    if key in ("mean_diameter", "density", "count"):
        return number(plan["sample"].get(key))
    if key in plan:
        return number(plan[key])
    tests = [t for t in plan.get("tests", []) if test is None or t["name"] == test]
    return number(tests[0].get(key)) if tests else None


def solid_volume(entry):
    return binary.solid_volume(entry["plan"]) if entry.get("plan") else None


def run_cost(entry):
    """(cpu_s, wall_s) of a run's tests. CPU time of the single-threaded run is what it costs on an idle core; the
    wall time of a shared machine also counts time given to other jobs."""
    tests = (entry["summary"].get("tests") or {})
    wall = sum(t.get("wall_s", 0.0) for t in tests.values() if isinstance(t, dict)) or entry["outcome"].get("wall_s")
    return entry["outcome"].get("cpu_s"), wall


# ---- analysis: the study ------------------------------------------------------------------------------------------

def within_time_step_warning(plan):
    """Whether a deck's time step is at most the bound above which celldem warns (its plan.json's
    time_step_bounds: the bound with action "warn", when "above"; core/plan's stable_fraction of the critical
    time step); None for a plan without that table."""
    bounds = [number(b.get("time_step")) for b in (plan or {}).get("time_step_bounds") or []
              if b.get("action") == "warn" and b.get("when") == "above"]
    dt = number((plan or {}).get("time_step"))
    if dt is None or not bounds or None in bounds:
        return None
    return dt <= min(bounds)


def describe(entry):
    """What a run's deck implies, from its plan.json (None without one)."""
    dt, t_c = planned(entry, "time_step"), planned(entry, "normal_time_step")
    return {"dt_over_tc": dt / t_c if dt and t_c else planned(entry, "time_step_ratio"),  # in sqrt(m_min/kn)
            "dt_within_warning": within_time_step_warning(entry.get("plan")),
            "rate": planned(entry, "strain_rate"),
            "inertial_number": planned(entry, "inertial_number"),
            "steps_per_test": None if planned(entry, "steps") is None else int(planned(entry, "steps"))}


def servo_cap(entry):
    """servo.max_strain_increment of a run: its summary.json setting, else what its spec asked, else None."""
    cap = setting(entry, "servo_max_strain_increment")
    return cap if cap is not None else number((entry["spec"].get("servo") or {}).get("max_strain_increment"))


def setting_rows(results, roles, refs, ref_mean, floor):
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
                k = kinetic_ratio(ser, solid_volume(e))
                if k is not None and k.size > 1:
                    ke_max = max(ke_max or 0.0, float(np.nanmax(k[1:])))
                info = (e["summary"].get("tests") or {}).get(test) or {}
                if isinstance(info.get("servo_max_error"), (int, float)):
                    servo_max[test] = max(servo_max.get(test, 0.0), float(info["servo_max_error"]))
        first = (good or entries)[0]
        sample = results.get(spec.get("sample"))
        sample_cap = servo_cap(sample) if sample is not None else number(spec.get("sample_cap"))
        row = {"key": key, "group": spec["group"], "label": spec["label"] if key != "reference" else "paper settings",
               "seeds": sorted(e["spec"]["seed"] for e in good), "failed": len(entries) - len(good),
               "count": spec["count"], "time_step": spec["time_step"], "strain_increment": spec["strain_increment"],
               "servo_max_strain_increment": servo_cap(first),
               "sample_time_step": spec.get("sample_dt", spec["value"] if spec["group"] == "prepare_dt" else PAPER_DT),
               "sample_servo_cap": sample_cap if sample_cap is not None else servo_cap(first),
               "density_factor": spec.get("density_factor", 1.0), "damping": spec["damping"],
               "output_interval": spec["output_interval"], "cost": float(np.mean(cpu)) if cpu else None,
               "wall": float(np.mean(wall)) if wall else None,
               "errors": {f"{t}.{q}": list(v) for (t, q), v in errs.items()},
               "ke_max": ke_max, "servo_max_error": max(servo_max.values()) if servo_max else None,
               "servo_max_error_by_test": servo_max,
               "score": score_of(errs) if good and finite else (None if not good else math.inf)}
        row["score_stress"], row["score_volume"] = split_scores(errs) if finite else (math.inf, math.inf)
        row.update(describe(first))
        if key == "reference":
            row["score"] = row["score_stress"] = row["score_volume"] = 0.0
        rows.append(row)
    return rows


def choose_presets(rows):
    """The presets (PRESET_RULES): for each, the cheapest setting of the table that meets its rule, with its
    speed-up over the reference."""
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
            # The ratio of the tests' steps (plan.json) of the reference and the setting: both run to the same strain,
            # so it is the ratio for the full decks too (up to the rounding of the steps).
            speedup = (ref_row["steps_per_test"] / best["steps_per_test"]
                       if ref_row["steps_per_test"] and best["steps_per_test"] else None)
            # Its own preparation would run with its time step and servo cap; where no sample prepared so was
            # shown to meet the rule, the preset starts from the paper's prepared sample, as the study's runs did.
            own = preparation_ok(rows, best["time_step"], best["servo_max_strain_increment"], rule,
                                 ref_row["servo_max_strain_increment"])
            presets[name] = {"row": best["key"], "label": best["label"], "rule": rule["text"],
                             "preparation": "own" if own else "paper",
                             "time_step": best["time_step"], "dt_over_tc": best["dt_over_tc"],
                             "strain_increment": best["strain_increment"],
                             "servo_max_strain_increment": best["servo_max_strain_increment"],
                             "output_interval": best["output_interval"],
                             "inertial_number": best["inertial_number"], "score": best["score"],
                             "score_stress": best["score_stress"], "score_volume": best["score_volume"],
                             "seeds": best["seeds"], "errors": best["errors"],
                             "test_steps_speedup": speedup,
                             "measured_speedup": (ref_row["cost"] / best["cost"]) if best["cost"] else None}

    return presets


def modelling_choices(ok, refs, floor):
    """The modelling choices' signed mean errors over the reference seeds, each quantity in floors too."""
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

    return modelling


def analyse(root):
    """The study of the run folders under `root`: noise floor, settings' errors and costs, Pareto front, presets,
    modelling choices, stability; a dict that study_report draws and writes (and study.json keeps)."""
    results = load_results(root)
    ok = {n: e for n, e in results.items() if e["outcome"].get("rc") == 0}

    refs = {e["spec"]["seed"]: e for n, e in ok.items() if e["spec"].get("role") == "reference"}
    ref_metrics = [refs[s]["metrics"] for s in sorted(refs)]
    mean, floor = noise_floor(ref_metrics)
    ref_mean = {}
    for (test, name), v in mean.items():
        ref_mean.setdefault(test, {})[name] = v

    rows = setting_rows(results, ("accuracy", "reference"), refs, ref_mean, floor)
    cap_rows = setting_rows({n: e for n, e in results.items() if e["spec"].get("group") == "servo_cap"},
                            ("stability",), refs, ref_mean, floor)
    group_order = ["reference", "null", "strain_increment", "time_step", "density", "combined", "damping",
                   "output_interval", "count", "prepare_dt"]
    rows.sort(key=lambda r: (group_order.index(r["group"]) if r["group"] in group_order else 99,
                             r["cost"] if r["cost"] is not None else 0))
    points = [(r["cost"], max(r["score"], 1e-3) if r["score"] is not None else None) for r in rows]
    front = pareto_front(points)
    for i, r in enumerate(rows):
        r["pareto"] = i in front

    presets = choose_presets(rows)
    modelling = modelling_choices(ok, refs, floor)
    stability = analyse_stability(results, floor)
    limits = thresholds(rows, cap_rows, stability)
    samples = {n: {"spec": e["spec"], "prepared": e["summary"].get("prepared"), "outcome_rc": e["outcome"].get("rc"),
                   "cpu_s": e["outcome"].get("cpu_s")}
               for n, e in results.items() if e["spec"].get("kind") == "sample"}
    hosts = sorted({e["outcome"].get("host") for e in results.values() if e["outcome"].get("host")})
    peaks = {f"{t}": [refs[s]["metrics"].get(t, {}).get("e1_peak") for s in sorted(refs)] for t in ("ttc", "psc")}
    ref = refs[min(refs)] if refs else {}
    servo_run = next((e for e in results.values() if e["spec"].get("group") == "stability_servo"), {})
    windows = {number(((e["summary"].get("tests") or {}).get(t) or {}).get("end_window", {}).get("strain"))
               for e in refs.values() for t in e["metrics"]} - {None}
    # The study's unit: sqrt(m_min/kn), the normal mode's limit (older plans: the critical time step, which was that).
    t_c = planned(ref, "normal_time_step") or planned(ref, "critical_time_step")
    dt = planned(ref, "time_step")
    return {"scene": {"count": SCENE_COUNT, "end_strain": END_STRAIN, "t_c": t_c,
                      "critical_time_step": planned(ref, "critical_time_step"),
                      "d_mean": planned(ref, "mean_diameter"), "density": planned(ref, "density"),
                      "p": P_REF, "paper_dt_over_tc": dt / t_c if dt and t_c else None,
                      "paper_inertial_number": planned(ref, "inertial_number"),
                      "servo_inertial_number": planned(servo_run, "inertial_number"),
                      "end_window": windows.pop() if len(windows) == 1 else None,
                      "reference_seeds": sorted(refs), "hosts": hosts, "reference_e1_at_peak": peaks},
            "noise_floor": {f"{t}.{q}": [mean[(t, q)], floor[(t, q)]] for t, q in QUANTITIES},
            "binaries": read_json(os.path.join(root, "binaries.json")) or [],
            "thresholds": limits, "rows": rows, "servo_cap_rows": cap_rows, "presets": presets,
            "modelling": modelling, "stability": stability, "samples": samples}


# The time-to-answer rules (solver/io/time_to_answer_rules.json): celldem's `--tolerance T` rewrites a deck by them.
RULES_MIN_TOLERANCE = 0.5   # below about 0.7 floors no setting can be told from the reference (round-off alone)
RULES_MAX_TOLERANCE = 3.0   # the table ends here: larger errors are not an answer


def rules_levels(study):
    """The levels of the time-to-answer rules from a study: at each tolerance T (noise floors) the cheapest setting
    (fewest test steps) whose error is at most T, for the settings a whole deck can carry (the presets'
    candidates, at a time step celldem does not warn about); one level per setting of the Pareto front of steps
    against error, the reference's at RULES_MIN_TOLERANCE, up to RULES_MAX_TOLERANCE. The time step is a fraction
    of the stability limit celldem applies (the reference plan's critical_time_step) and the loading rate an
    inertial number; each level carries its evidence (the setting, its error, its speed-up in test steps, whether
    its preparation was measured)."""
    limit = study["scene"].get("critical_time_step")
    rows = [r for r in study["rows"] if r["group"] in ("reference", "strain_increment", "time_step", "combined")
            and r["count"] == SCENE_COUNT and len(r["seeds"]) >= 2 and r.get("score") is not None
            and math.isfinite(r["score"]) and r["dt_within_warning"] is not False and r.get("steps_per_test")
            and r.get("inertial_number")]
    ref = next((r for r in rows if r["key"] == "reference"), None)
    if ref is None or not limit:
        return []
    levels = []
    by_score = sorted(rows, key=lambda r: (r["score"], r["steps_per_test"]))
    for row in by_score:
        tolerance = max(row["score"], RULES_MIN_TOLERANCE) if row is not ref else RULES_MIN_TOLERANCE
        if tolerance > RULES_MAX_TOLERANCE:
            break
        best = cheapest_within(rows, tolerance, cost_key="steps_per_test")
        if best is not row:
            continue  # a cheaper setting is at least as accurate: it is that level
        if levels and levels[-1]["tolerance"] >= tolerance:
            continue
        own_preparation = row is ref or preparation_ok(study["rows"], row["time_step"], row["servo_max_strain_increment"],
                                                       {"stress": tolerance, "volume": tolerance},
                                                       ref["servo_max_strain_increment"])
        fraction = row["time_step"] / limit
        levels.append({
            "tolerance": round(tolerance, 4), "time_step_fraction": round(fraction, 4),
            "prepare_time_step_fraction": round(fraction, 4), "inertial_number": float(f"{row['inertial_number']:.4g}"),
            "fast_strain_increment_scale": 1.0, "damping_scale": 1.0,
            "evidence": {"run": f"{row['key']}: {row['label']}", "error_floors": round(row["score"], 3),
                         "speedup": round(ref["steps_per_test"] / row["steps_per_test"], 3), "measured": True,
                         "seeds": row["seeds"],
                         "note": "tests measured on the study's scene; the preparation at this time step "
                                 + ("measured" if own_preparation else "extrapolated (no sample prepared so was run)")}})
    return levels


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
    # Loading rate: settings at a time step celldem does not warn about, by inertial number.
    stable_rows = [r for r in rows if r.get("dt_within_warning") and r["group"] in
                   ("reference", "null", "strain_increment", "time_step", "density", "combined")
                   and r.get("score_stress") is not None]
    ok_i = [r["inertial_number"] for r in stable_rows if r["score_stress"] <= 1.0 and r["inertial_number"]]
    bad_i = [r["inertial_number"] for r in stable_rows if r["score_stress"] > 1.0 and r["inertial_number"]]
    out["I_stress_ok_max"] = max(ok_i) if ok_i else None
    out["I_stress_bad_min"] = min(bad_i) if bad_i else None
    ok_v = [r["inertial_number"] for r in stable_rows if r["score_volume"] is not None and r["score_volume"] <= 2.0
            and r["inertial_number"]]
    out["I_volume_ok_max"] = max(ok_v) if ok_v else None
    out["ke_quasi_static_max"] = max((r["ke_max"] for r in stable_rows if r.get("ke_max") is not None
                                      and r["score_stress"] <= 1.0), default=None)
    # Servo: the cap on the strain per step, and the gains.
    capped = [(r["strain_increment"] / r["servo_max_strain_increment"], r["servo_max_error"]) for r in cap_rows
              if r.get("servo_max_error") is not None and r["servo_max_strain_increment"]]
    tolerance = servo_tolerance()  # the solver's bound on servo_max_error
    out["cap_ratio_ok_max"] = max((x for x, e in capped if e <= tolerance), default=None)
    out["cap_ratio_bad_min"] = min((x for x, e in capped if e > tolerance), default=None)
    out["servo_max_error_reference"] = max((r["servo_max_error"] for r in rows if r["group"] == "reference"
                                            and r.get("servo_max_error") is not None), default=None)
    servo = [r for r in stability["servo"] if r.get("std") is not None]
    out["servo_failing"] = [[r["gain"], r["integral_gain"], r["std"], r["bias"]] for r in servo if not r["holds"]]
    out["servo_std_max_holding"] = max((r["std"] for r in servo if r["holds"]), default=None)
    return out


def stress_targets(entry, test):
    """{column: target} of the stress-controlled axes of `test` (plan.json; the TTC's P_REF without a plan)."""
    plan = entry.get("plan")
    if not plan:
        return {"s22": P_REF, "s33": P_REF}
    axes = binary.test_plan(plan, test)["axes"]
    return {f"s{a[1]}{a[1]}": ax["stress"] for a, ax in axes.items() if "stress" in ax}


def analyse_stability(results, floor):
    """Time step × damping, servo gains, and error against the inertial number."""
    return {"dt": stability_dt_rows(results, floor), "servo": servo_gain_rows(results)}


def stability_dt_rows(results, floor):
    """The time step × damping runs, by damping then time step: each one's kinetic energy, its drift from the same
    damping's run at the paper's time step, and its state (blow-up, unstable, drift, stable or failed)."""
    rows = []
    stab = {n: e for n, e in results.items() if e["spec"].get("group") == "stability_dt"}
    # The baseline of each damping value: its run at the paper's time step.
    base = {}
    for n, e in stab.items():
        s = e["spec"]
        if abs(s["time_step"] - PAPER_DT) < 1e-12 and e["outcome"].get("rc") == 0 and "ttc" in e["series"]:
            base[s["damping"][0]] = e
    for n, e in sorted(stab.items(), key=lambda kv: (kv[1]["spec"]["damping"][0], kv[1]["spec"]["time_step"])):
        s = e["spec"]
        row = {"name": n, "dt_over_tc": s["value"], "damping": s["damping"][0], "rc": e["outcome"].get("rc")}
        series = e["series"].get("ttc")
        if e["outcome"].get("rc") != 0 or series is None:
            row.update(state="failed", message=(e["outcome"].get("log_tail") or "").strip().splitlines()[-1:]
                       if e["outcome"].get("log_tail") else [])
            rows.append(row)
            continue
        finite = all_finite(series)
        ke_rel = kinetic_ratio(series, solid_volume(e))
        if ke_rel is None:
            row["ke_max"] = None
        elif np.all(np.isfinite(ke_rel)):
            row["ke_max"] = float(np.max(ke_rel[1:])) if ke_rel.size > 1 else float(ke_rel[0])
        else:
            row["ke_max"] = math.inf
        b = base.get(s["damping"][0])
        if b is not None and b is not e:
            row.update(drift_from_base(series, b["series"]["ttc"], s["end_strain"], floor))
        drift = row.get("ratio_drift") is not None and row["ratio_drift"] > DRIFT_FLOORS
        row["state"] = ("blow-up" if not finite else "unstable" if (row["ke_max"] or 0.0) > KE_UNSTABLE
                        else "drift" if drift else "stable")
        rows.append(row)
    return rows


def drift_from_base(series, bs, end_strain, floor):
    """A stability run's TTC against its damping's run at the paper's time step `bs`: the curves' differences
    (σ1/σ3, εv; relative to their range) and the drift of σ1/σ3 over the last fifth of the run, in TTC peak noise
    floors."""
    dev = []
    for col in ("ratio13", "ev"):
        diff, _ = curve_difference(series["e1"], series[col], bs["e1"], bs[col], bins=20,
                                   relative_to="range")
        dev.append(diff)
    # Drift of σ1/σ3 at the end of the run (mean over its last fifth), against the TTC peak's noise floor.
    end = min(end_strain, float(np.nanmax(series["e1"])), float(np.nanmax(bs["e1"])))

    def tail_mean(x, y):
        keep = (x >= 0.8 * end) & (x <= end) & np.isfinite(y)
        return float(np.mean(y[keep])) if np.any(keep) else None

    end_r, end_b = tail_mean(series["e1"], series["ratio13"]), tail_mean(bs["e1"], bs["ratio13"])
    f = floor.get(("ttc", "peak_ratio"))
    return {"ratio_drift": abs(end_r - end_b) / f if end_r is not None and end_b is not None and f else None,
            "curve_diff_ratio": dev[0], "curve_diff_ev": dev[1]}


def servo_gain_rows(results):
    """The servo gain runs: the std, bias and largest error of the held stresses, and whether the servo holds."""
    rows = []
    for n, e in sorted(results.items()):
        s = e["spec"]
        if s.get("group") != "stability_servo":
            continue
        row = {"name": n, "gain": s["servo"]["gain"], "integral_gain": s["servo"]["integral_gain"],
               "rc": e["outcome"].get("rc")}
        series = e["series"].get("ttc")
        if e["outcome"].get("rc") == 0 and series is not None:
            row["std"], row["bias"], row["max"] = servo_error_stats(series, stress_targets(e, "ttc"))
            row["peak_ratio"] = e["metrics"]["ttc"]["peak_ratio"]
            row["holds"] = row["std"] is not None and row["std"] <= SERVO_STD_LIMIT and row["bias"] <= SERVO_STD_LIMIT
        rows.append(row)
    return rows
