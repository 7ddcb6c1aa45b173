"""`celldem run --verify-rate` on a small deck (tests/run/small_run.json, 150 spheres, tests to 2 % of axial
strain) at two driving rates, the paper's strain increment (inputs/paper.json's tests) and a hundred times it.
The check runs each test again from the same prepared state over its whole path at half the rate, and a twin
(the test at 1.001 times its rate) whose differences calibrate the chaos of one pair of runs:

- at the paper's rate no quantity and no test is "not converged";
- the run a hundred times too fast (inertial number near 1e-2, which the run warns of) is "not converged": a
  whole-path check sees the rate's effect built up along the path (a check that re-ran only a short window
  before the end from the fast run's own state did not);
- every verdict is recomputed here from the numbers summary.json gives (the twin's differences, the floors, the
  rate factor) with SciPy: per quantity the chaos's 95 % half-width (the smaller of t(0.975, 1) |twin difference|
  and z(0.975) sqrt 2), the error extrapolated to the quasi-static limit and the three-way verdict; likewise the
  ensemble's TOST over the seeds;
- the slower run and the twin start from the test's own starting state (their first rows are the test's), the
  slower run takes twice the steps, the test's own series are the bytes of a run without --verify-rate, and the
  check gives the same bytes on one thread and on two;
- its cost is printed before it runs; a test's verify_rate key asks for the check of that test alone, and a bad
  value of it or a floors file without floors is refused with exit 2 naming the key;
- a run at `--tolerance 1` prints the tolerance, the predicted saving and the rules' floors at this size before it
  starts, and each verdict after each test, as summary.json holds them.

About two minutes of CPU.

Usage: CELLDEM=build/celldem /usr/bin/python3 -m pytest tests/run/test_verify_rate.py (ctest: run_verify_rate)
"""
import csv
import json
import math
import os
import subprocess

import pytest
from scipy import stats

pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
END_STRAIN = 0.02
STRAIN_PER_ROW = 2.5e-4  # the same rows per strain at every rate (a peak's row sampling does not change)
FLOOR_OF = {"peak_ratio13": "ratio13", "peak_robust.ratio13": "ratio13", "end_window.ev": "ev", "end_window.Z": "Z"}


def paper_increment():
    with open(os.path.join(ROOT, "inputs", "paper.json")) as f:
        paper = json.load(f)
    increments = {t["axes"]["x1"]["strain_increment"] for t in paper["tests"]}
    assert len(increments) == 1, increments
    return increments.pop()


def deck_at(increment, folder, name):
    with open(os.path.join(ROOT, "tests", "run", "small_run.json")) as f:
        deck = json.load(f)
    if name != "paper_rate":  # too fast for the servo to hold x2 and x3: the run goes on, marked uncontrolled
        deck["control_failure"] = "warn"
    for test in deck["tests"]:
        test["axes"]["x1"]["strain_increment"] = increment
        test["end"]["strain"] = END_STRAIN
        test["output_interval"] = max(1, round(STRAIN_PER_ROW / increment))
    path = os.path.join(folder, name + ".json")
    with open(path, "w") as f:
        json.dump(deck, f)
    return path


def run(celldem, deck, out, *extra, quiet=True):
    result = subprocess.run([celldem, "run", deck, "--out", out, *(["--quiet"] if quiet else []), *extra],
                            capture_output=True, text=True)
    assert result.returncode == 0, f"{deck} {extra}: exit {result.returncode}: {result.stderr[-2000:]}"
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return (summary, result.stdout) if not quiet else summary


def verdicts(summary):
    return {test: t["verify_rate"]["verdict"] for test, t in summary["tests"].items()}


def read(path):
    with open(path, "rb") as f:
        return f.read()


def first_row(path):
    with open(path) as f:
        return next(csv.DictReader(f))


def oracle_verdict(error, half_width, tolerance):
    if abs(error) + half_width <= tolerance:
        return "converged"
    if abs(error) - half_width > tolerance:
        return "not converged"
    return "unresolved"


def check_against_oracle(v):
    """Recomputes a test's verify_rate verdicts from its numbers with SciPy: per quantity the chaos's 95 % half-width,
    the smaller of t(0.975, 1) |twin difference| and z(0.975) sqrt 2 (Bonferroni), extrapolated as the error is."""
    twin = [c["twin_floors"] for c in v["comparisons"].values() if isinstance(c.get("twin_floors"), (int, float))]
    parted = bool(twin) and math.sqrt(sum(t * t for t in twin) / len(twin)) >= 1e-3
    assert v["chaos"]["twin_parted"] == parted
    bound = stats.norm.ppf(0.975) * math.sqrt(2)
    assert v["chaos"]["bound_half_width_floors"] == pytest.approx(bound, rel=1e-12)
    assert v["chaos"]["twin_quantile"] == pytest.approx(stats.t.ppf(0.975, 1), rel=1e-6)  # (SciPy's t.ppf: ~1e-9)
    scale = 1 / (1 - v["rate_factor"])
    tests = []
    for q, c in v["comparisons"].items():
        if "error_floors" not in c:
            assert c["verdict"] == "not compared"
            tests.append("not compared")
            continue
        floor = v["floors"][FLOOR_OF[q]]
        assert c["floor"] == floor
        assert c["floors"] == pytest.approx((c["test"] - c["slow"]) / floor, rel=1e-9, abs=1e-12)
        assert c["error_floors"] == pytest.approx(c["floors"] * scale, rel=1e-9, abs=1e-12)
        if parted and isinstance(c.get("twin_floors"), (int, float)):
            assert c["twin_floors"] == pytest.approx((c["test"] - c["twin"]) / floor, rel=1e-9, abs=1e-12)
            half = min(stats.t.ppf(0.975, 1) * abs(c["twin_floors"]), bound)
        else:
            half = bound
        assert c["chaos_half_width_floors"] == pytest.approx(half * scale, rel=1e-6)
        expected = oracle_verdict(c["error_floors"], half * scale, v["tolerance_floors"])
        assert c["verdict"] == expected, f"{q}: {c} against {expected}"
        tests.append(expected)
    overall = ("not converged" if "not converged" in tests else
               "converged" if all(t == "converged" for t in tests) else "unresolved")
    assert v["verdict"] == overall, f"{v['verdict']} against {overall}: {v['reason']}"


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return str(tmp_path_factory.mktemp("verify_rate"))


@pytest.fixture(scope="module")
def fast(celldem, work):
    """The deck a hundred times the paper's rate, and its run with --verify-rate on one thread (not quiet)."""
    deck = deck_at(100 * paper_increment(), work, "too_fast")
    summary, stdout = run(celldem, deck, os.path.join(work, "fast"), "--verify-rate", "--threads", "1", quiet=False)
    return deck, summary, stdout


def test_at_the_papers_rate_nothing_is_not_converged(celldem, work):
    slow = run(celldem, deck_at(paper_increment(), work, "paper_rate"), os.path.join(work, "paper"), "--verify-rate",
               "--threads", "1")
    for test, t in slow["tests"].items():
        v = t["verify_rate"]
        check_against_oracle(v)
        assert v["verdict"] != "not converged", f"{test}: at the paper's rate: {v['reason']}"
        assert all(c["verdict"] != "not converged" for c in v["comparisons"].values()), v["comparisons"]
        assert v["chaos"]["twin_parted"], f"{test}: the twin parts from the test: {v['chaos']}"


def test_a_run_too_fast_is_not_converged(fast):
    _, summary, stdout = fast
    v = verdicts(summary)
    assert "not converged" in v.values(), f"a run 100 x too fast is not converged: {v}"
    for test, t in summary["tests"].items():
        check_against_oracle(t["verify_rate"])
        assert f"{test}: rate check: {t['verify_rate']['verdict']}" in stdout, "the verdict is printed"


def test_the_cost_is_printed_before_the_check_runs(fast):
    _, summary, stdout = fast
    for test, t in summary["tests"].items():
        announced = stdout.index(f"{test}: rate check after the test: ")
        assert announced < stdout.index(f"{test}: done"), "the cost comes before the test is done"
        cost = t["verify_rate"]["cost"]
        assert f"{cost['slow_steps']} steps at the slower rate and {cost['twin_steps']} of the twin" in \
            stdout[announced:], stdout[announced:][:300]
        assert cost["slow_steps"] == t["verify_rate"]["runs"]["slow"]["steps"], "the predicted steps are run"


def test_the_runs_start_from_the_tests_start_and_leave_its_series_alone(celldem, work, fast):
    fast_deck, summary, _ = fast
    plain = run(celldem, fast_deck, os.path.join(work, "plain"), "--threads", "1")
    for test, t in summary["tests"].items():
        assert read(os.path.join(work, "fast", test, "series.csv")) == \
            read(os.path.join(work, "plain", test, "series.csv")), f"{test}: --verify-rate changed the test's own series"
        assert "verify_rate" not in plain["tests"][test], f"{test}: verify_rate without --verify-rate"
        own = first_row(os.path.join(work, "fast", test, "series.csv"))
        runs = t["verify_rate"]["runs"]
        for name in ("slow", "twin"):
            row = first_row(os.path.join(work, "fast", runs[name]["series"]))
            for k in ("step", "e1", "e2", "e3", "s11", "s22", "s33", "ev", "Z"):
                assert row[k] == own[k], f"{test} {name}: first row {k} {row[k]} is not the test's {own[k]}"
        # The slower run covers the same strain at half the rate: twice the steps (within a step of each leg's end);
        # the twin at 1.001 times the rate.
        assert abs(runs["slow"]["steps"] - 2 * t["steps"]) <= 2, (runs["slow"]["steps"], t["steps"])
        assert abs(runs["twin"]["steps"] - t["steps"] / 1.001) <= 2, (runs["twin"]["steps"], t["steps"])


def test_the_check_gives_the_same_bytes_on_two_threads(celldem, work, fast):
    fast_deck, summary, _ = fast
    run(celldem, fast_deck, os.path.join(work, "two"), "--verify-rate", "--threads", "2", "--fixed-threads")
    for test, t in summary["tests"].items():
        for name, r in t["verify_rate"]["runs"].items():
            assert read(os.path.join(work, "fast", r["series"])) == read(os.path.join(work, "two", r["series"])), \
                f"{test} {name}: the series differs between 1 and 2 threads"


def test_an_ensemble_judges_the_mean_by_tost(celldem, work):
    deck = deck_at(100 * paper_increment(), work, "too_fast_seeds")
    out = os.path.join(work, "seeds")
    subprocess.run([celldem, "run", deck, "--out", out, "--quiet", "--verify-rate", "--no-verify-twin", "--seeds", "1-3",
                    "--threads", "1"], check=True, capture_output=True, text=True)
    with open(os.path.join(out, "ensemble.json")) as f:
        ensemble = json.load(f)
    assert set(ensemble["verify_rate"]) == {"ttc", "psc"}
    for test, e in ensemble["verify_rate"].items():
        errors = {}
        for seed in (1, 2, 3):
            with open(os.path.join(out, f"seed-{seed}", "summary.json")) as f:
                v = json.load(f)["tests"][test]["verify_rate"]
            assert not v["chaos"]["twin_parted"] and \
                all(c.get("chaos_from", "bound") == "bound" for c in v["comparisons"].values()), "no twin: the bound"
            check_against_oracle(v)
            for q, c in v["comparisons"].items():
                if "error_floors" in c:
                    errors.setdefault(q, []).append(c["error_floors"])
        verdicts_q = []
        for q, values in errors.items():
            r = e["quantities"][q]
            n = len(values)
            mean = sum(values) / n
            se = stats.tstd(values) / math.sqrt(n)
            half = stats.t.ppf(0.95, n - 1) * se
            assert r["mean"] == pytest.approx(mean) and r["bounds95"] == pytest.approx([mean - half, mean + half])
            T = e["tolerance_floors"]
            expected = ("converged" if mean - half > -T and mean + half < T else
                        "not converged" if mean - half > T or mean + half < -T else "unresolved")
            assert r["verdict"] == expected, (q, r, expected)
            verdicts_q.append(expected)
        assert e["verdict"] == ("not converged" if "not converged" in verdicts_q else
                                "converged" if all(x == "converged" for x in verdicts_q) else "unresolved")
    assert "not converged" in {e["verdict"] for e in ensemble["verify_rate"].values()}, ensemble["verify_rate"]


def test_the_deck_key_asks_for_one_test_and_bad_values_are_refused(celldem, work, fast):
    fast_deck, _, _ = fast
    with open(fast_deck) as f:
        keyed = json.load(f)
    keyed["tests"][1]["verify_rate"] = {"rate_factor": 0.25, "twin": False}
    keyed_deck = os.path.join(work, "keyed.json")
    with open(keyed_deck, "w") as f:
        json.dump(keyed, f)
    by_key = run(celldem, keyed_deck, os.path.join(work, "keyed"), "--threads", "1")
    name0, name1 = keyed["tests"][0]["name"], keyed["tests"][1]["name"]
    assert "verify_rate" not in by_key["tests"][name0], f"{name0}: checked without being asked"
    v = by_key["tests"][name1]["verify_rate"]
    assert v["rate_factor"] == 0.25 and "twin" not in v["runs"] and not v["chaos"]["twin_parted"], v
    check_against_oracle(v)
    keyed["tests"][1]["verify_rate"] = {"twin": 3}
    with open(keyed_deck, "w") as f:
        json.dump(keyed, f)
    bad = subprocess.run([celldem, "check", keyed_deck], capture_output=True, text=True)
    assert bad.returncode == 2 and "tests[1].verify_rate.twin" in bad.stderr, \
        f"a bad value: exit 2 naming the key, got {bad.returncode}: {bad.stderr}"
    bad = subprocess.run([celldem, "run", fast_deck, "--out", os.path.join(work, "bad"), "--verify-rate", "--floors",
                          os.path.join(ROOT, "tests", "run", "small_run.json")], capture_output=True, text=True)
    assert bad.returncode == 2 and "ratio13" in bad.stderr, \
        f"a floors file without floors: exit 2 naming the key, got {bad.returncode}: {bad.stderr}"


def test_a_tolerance_run_prints_its_tolerance_saving_and_verdicts(celldem, work):
    """`--tolerance 1 --verify-rate`: the run prints the tolerance it applied, the predicted saving and what T floors
    of this deck are in the rules' 1000-sphere scene before it starts, and each rate-check verdict after
    each test; summary.json holds the same (its tolerance block as `celldem plan --tolerance 1 --json` gives it)."""
    deck = deck_at(paper_increment(), work, "tolerance")
    summary, stdout = run(celldem, deck, os.path.join(work, "tolerance"), "--tolerance", "1", "--verify-rate",
                          "--no-verify-twin", "--threads", "1", quiet=False)
    plan = json.loads(subprocess.run([celldem, "plan", deck, "--tolerance", "1", "--json"], capture_output=True,
                                     text=True, check=True).stdout)["tolerance"]
    t = summary["tolerance"]
    assert t["total"] == plan["total"] and t["tolerance"] == 1
    ratio = t["total"]["ratio_low"]
    first = stdout.splitlines()[0]
    assert first.startswith("tolerance 1 noise floors") and f"{ratio:.2f}x fewer" in first, first
    c = t["calibration"]
    # 150 spheres, fewer than the rules' 1000: the deck keeps T (its wider floors are not spent).
    assert c["calibration_particles"] == 1000 and c["particles"] == 150 and c["tolerance_at_calibration"] == 1
    assert "1 floors of these 150 spheres are 1 floors of the rules' 1000-sphere scene" in first, first
    for test, s in summary["tests"].items():
        v = s["verify_rate"]
        assert v["tolerance_floors"] == 1
        assert f"{test}: rate check: {v['verdict']}: " in stdout
        for q, c in v["comparisons"].items():
            assert f"{test}:   {q:<20s} " in stdout and c["verdict"] in stdout
