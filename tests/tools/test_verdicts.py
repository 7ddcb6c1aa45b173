"""pytest: the reports refuse what they cannot judge (uncontrolled tests, tests without a peak) and the failure
surface fits nothing it cannot fit."""

import pytest

from celldem.reports import ensemble_report, failure_surface, report
from celldem.results import Ensemble, Run


def run(seed, psc_controlled=True):
    tests = {"ttc": {"servo_max_error": 0.001, "legs": [{"leg": 0, "control_errors": {"stress": 0.001, "b": None}}]},
             "psc": {"servo_max_error": 1.38, "controlled": psc_controlled,
                     "control_failures": [] if psc_controlled else ["leg 0 x3 stress: 138 % > 0.5 %"],
                     "legs": [{"leg": 0, "control_errors": {"stress": 1.38}}]}}
    return Run(f"/nowhere/seed-{seed}", {"tests": tests}, {"ttc": {}, "psc": {}})


def paired_stats(excluded):
    diff = {"n": 3, "mean": -0.9, "std": 0.02, "sem": 0.0115, "ci95": [-0.95, -0.85], "values": [-0.9] * 3}
    out = {"seeds": [1, 2, 3], "paired": {"ttc-psc": {"peak_ratio13": diff}}}
    if excluded:
        out["excluded"] = {"rule": "uncontrolled tests left out", "tests": {}}
    return out


def test_no_ttc_lower_than_psc_on_uncontrolled_runs():
    ens = Ensemble("/nowhere", paired_stats(excluded=False), [run(1), run(2, psc_controlled=False), run(3)])
    text = ensemble_report.paired_section(ens)
    assert "ttc lower than psc" not in text
    assert "not judged: uncontrolled runs in the pair" in text
    # celldem left them out itself: the pair's statistics hold controlled runs only, and a verdict is given
    ens = Ensemble("/nowhere", paired_stats(excluded=True), [run(1), run(2, psc_controlled=False), run(3)])
    assert "ttc lower than psc" in ensemble_report.paired_section(ens)


def test_controls_section_marks_uncontrolled_tests():
    text = report.controls_section(run(1, psc_controlled=False))
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
