"""pytest: the reports refuse what they cannot judge (uncontrolled tests, tests without a peak) and the failure
surface fits nothing it cannot fit."""

import json
import os

import numpy as np
import pytest

from celldem import results
from celldem.reports import ensemble_report, failure_surface, report


def write_run(folder, summary, series):
    """A run folder with `summary` as its summary.json and each test's series ({column: array}, or {} for a
    header-only series) as <test>/series.csv, opened as the tools open one (a view of celldem.api's Run)."""
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "summary.json"), "w") as f:
        json.dump(summary, f)
    for test, columns in series.items():
        os.makedirs(os.path.join(folder, test), exist_ok=True)
        names = list(columns) or ["e1"]
        rows = np.column_stack([columns[n] for n in names]) if columns else np.empty((0, 1))
        np.savetxt(os.path.join(folder, test, "series.csv"), rows, delimiter=",", fmt="%.17g",
                   header=",".join(names), comments="")
    return results.load_run(folder)


def write_ensemble(folder, stats):
    """An ensemble folder: `stats` as ensemble.json beside the seed-<k>/ run folders already written there."""
    with open(os.path.join(folder, "ensemble.json"), "w") as f:
        json.dump(stats, f)
    return results.load_ensemble(folder)


def run(folder, seed, psc_controlled=True):
    tests = {"ttc": {"servo_max_error": 0.001, "legs": [{"leg": 0, "control_errors": {"stress": 0.001, "b": None}}]},
             "psc": {"servo_max_error": 1.38, "controlled": psc_controlled,
                     "control_failures": [] if psc_controlled else ["leg 0 x3 stress: 138 % > 0.5 %"],
                     "legs": [{"leg": 0, "control_errors": {"stress": 1.38}}]}}
    return write_run(os.path.join(folder, f"seed-{seed}"), {"tests": tests}, {"ttc": {}, "psc": {}})


def paired_stats(excluded):
    diff = {"n": 3, "mean": -0.9, "std": 0.02, "sem": 0.0115, "ci95": [-0.95, -0.85], "values": [-0.9] * 3}
    out = {"seeds": [1, 2, 3], "paired": {"ttc-psc": {"peak_ratio13": diff}}}
    if excluded:
        out["excluded"] = {"rule": "uncontrolled tests left out", "tests": {}}
    return out


def test_no_ttc_lower_than_psc_on_uncontrolled_runs(tmp_path):
    run(tmp_path, 1), run(tmp_path, 2, psc_controlled=False), run(tmp_path, 3)
    ens = write_ensemble(tmp_path, paired_stats(excluded=False))
    text = ensemble_report.paired_section(ens)
    assert "ttc lower than psc" not in text
    assert "not judged: uncontrolled runs in the pair" in text
    # celldem left them out itself: the pair's statistics hold controlled runs only, and a verdict is given
    ens = write_ensemble(tmp_path, paired_stats(excluded=True))
    assert "ttc lower than psc" in ensemble_report.paired_section(ens)


def test_controls_section_marks_uncontrolled_tests(tmp_path):
    text = report.controls_section(run(tmp_path, 1, psc_controlled=False))
    assert "**UNCONTROLLED**: leg 0 x3 stress: 138 % > 0.5 %" in text
    assert "138 %" in text and "leg 0: stress 0.1 %" in text


def test_failure_surface_refuses_bad_tests():
    peak = {"sigma1": 3e5, "sigma2": 2e5, "sigma3": 1e5}
    summary = {"tests": {"b0": {"peak_state": peak, "peak_reached": False},
                         "b05": {"peak_state": peak, "controlled": False},
                         "b1": {"peak_state": peak}}}
    assert [n for n, _ in failure_surface.left_out(summary)] == ["b0", "b05"]
    points = failure_surface.peaks(summary)
    assert [p[0] for p in points] == ["b1"]
    with pytest.raises(ValueError, match="needs at least 2"):
        failure_surface.analyse("/nowhere", points)


# ---- the paper comparison: a verdict that matches what its row prints -------------------------------------------

def curve_run(folder, seed, rng):
    """A run with TTC and PSC series over ε1 to 12 %: σ1/σ3 rising to a peak, Hs11/Hs33 and b tracking it, ε2
    and TTC's b near 0 (as the tests prescribe), seed-to-seed scatter."""
    e1 = np.linspace(0.0, 0.12, 241)
    series = {}
    for test, peak in (("ttc", 3.0), ("psc", 3.8)):
        ratio = 1.0 + (peak - 1.0 + 0.1 * rng.standard_normal()) * (1.0 - np.exp(-e1 / 0.01))
        series[test] = {"e1": e1, "ratio13": ratio, "Hs11_Hs33": 1.0 + 0.3 * (ratio - 1.0) + 0.02 * rng.standard_normal(e1.size),
                        "b": (0.003 * rng.standard_normal(e1.size) if test == "ttc" else 0.3 + 0.05 * ratio),
                        "e2": (2e-6 * rng.standard_normal(e1.size) if test == "psc" else -e1 / 2)}
    summary = {"tests": {t: {"peak_reached": True} for t in series}}
    return write_run(os.path.join(folder, f"seed-{seed}"), summary, series)


def test_by_construction_rows_leave_the_holm_family_and_correlations_use_fisher_z(tmp_path):
    import math
    from scipy import stats as sps
    from celldem import stats
    rng = np.random.default_rng(3)
    for seed in (1, 2, 3, 4):
        curve_run(tmp_path, seed, rng)
    ens = write_ensemble(tmp_path, {"seeds": [1, 2, 3, 4], "paired": {}})
    claims = {c.label: c for c in ensemble_report.paper_claims(ens)}
    for label in ("PSC ε2 stays 0 (max |ε2|, %)", "TTC b stays 0 (max |b| for ε1 ≥ 0.1 %)"):
        c = claims[label]
        assert c.kind == "construction" and c.p == [] and c.verdict().startswith("by construction"), label
        assert "outside the Holm family" in c.test_text()
    # the family is every other claim's hypotheses: Holm over them alone
    flat = [p for c in claims.values() for p in c.p]
    adjusted, _ = stats.holm(flat)
    assert [a for c in claims.values() for a in c.adjusted] == adjusted
    text = ensemble_report.paper_section(ens)
    assert f"all {sum(p is not None for p in flat)} hypotheses" in text and "by construction" in text
    # Pearson r tracked through Fisher's z: the one-sample t of artanh(r) over the seeds against artanh(0.8)
    c = claims["psc: Hs11/Hs33 tracks σ1/σ3 (Pearson r)"]
    r = [sps.pearsonr(run.column("psc", "ratio13")[run.column("psc", "e1") >= 1e-3],
                      run.column("psc", "Hs11_Hs33")[run.column("psc", "e1") >= 1e-3])[0] for run in ens.runs]
    z = np.arctanh(np.clip(r, -1 + 1e-12, 1 - 1e-12))
    assert c.p[0] == pytest.approx(sps.ttest_1samp(z, math.atanh(0.8)).pvalue)
    assert c.verdict() == "yes" and c.interval_text().startswith("r = 0.99")


def test_a_value_outside_its_unadjusted_interval_says_so():
    from celldem import stats
    stat = stats.describe([1.0, 1.1, 0.9, 1.05, 0.95])
    lo, hi = stat["pi95"]
    paper = hi + 0.01  # outside the printed PI95
    c = ensemble_report.Claim("x", "paper", stat, 1.0, 3, "value", ensemble_report.PREDICTION, against=paper)
    assert c.p[0] < 0.05
    c.adjusted = [min(1.0, 3 * c.p[0])]  # in a family of three, the adjusted p passes 0.05
    assert c.adjusted[0] > 0.05
    v = c.verdict()
    assert v.startswith("consistent") and "outside the unadjusted PI95" in v and "not rejected after Holm" in v
    c.adjusted = [c.p[0]]  # rejected after adjustment too: a plain "no"
    assert c.verdict() == "no: below the paper"  # the ensemble lies below the paper's value
    inside = ensemble_report.Claim("x", "paper", stat, 1.0, 3, "value", ensemble_report.PREDICTION, against=1.0)
    inside.adjusted = list(inside.p)
    assert inside.verdict() == "consistent (the paper's value is a plausible seed)"
    # a paired difference whose 95 % interval excludes 0 without a Holm call says so too
    s = stats.describe([0.5, 0.6, 0.55])
    assert stats.lost_to_adjustment(stats.one_sample_p(s), 0.2) and s["ci95"][0] > 0
