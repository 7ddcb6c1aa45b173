"""`celldem run --verify-rate` on a small deck (tests/run/small_run.json, 150 spheres, tests to 2 % of axial
strain) at two driving rates, the paper's strain increment (inputs/paper.json's tests) and a hundred times it.
The check is a ladder: each test runs again from the same prepared state over its whole path at half and a quarter
of its rate (the rungs), and as two twins (1.001 and 1.002 times its rate) whose spread with the test is one run's
chaos; each quantity is fitted as Q0 + C r^p over the three rates and C, the test's distance from I -> 0, is judged
in floors:

- at the paper's rate no quantity and no test is "not converged";
- the run a hundred times too fast (inertial number near 1e-2, which the run warns of) is "not converged";
- every number is recomputed here from the values summary.json gives: the order and the distance by the closed
  form of three rates a factor 2 apart, the chaos as the sample std of the test and its twins (NumPy), the bounds
  by an independent simulation of the same propagation (NumPy, its own random numbers: within Monte Carlo error),
  and the three-way verdict with its Bonferroni level; likewise the ensemble's TOST over the seeds;
- the rungs and the twins start from the test's own starting state (their first rows are the test's), a rung at f
  takes 1/f of the steps, the test's own series are the bytes of a run without --verify-rate, and the check
  gives the same bytes on one thread and on two;
- each run's cost is printed before it runs; a test's verify_rate key asks for the check of that test alone, and a
  bad value of it (or of --verify-rate-rungs) or a floors file without floors is refused with exit 2 naming it;
- a run at `--tolerance 1` prints the tolerance and the predicted saving before it starts, and each verdict after
  each test, as summary.json holds them.

About a minute of CPU.

Usage: CELLDEM=build/celldem /usr/bin/python3 -m pytest tests/run/test_verify_rate.py (ctest: run_verify_rate)
"""
import csv
import json
import math
import os
import subprocess

import numpy as np
import pytest
from scipy import optimize, stats

pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
END_STRAIN = 0.02
STRAIN_PER_ROW = 2.5e-4  # the same rows per strain at every rate (a peak's row sampling does not change)
FLOOR_OF = {"peak_ratio13": "ratio13", "peak_robust.ratio13": "ratio13", "end_span.ev": "ev", "end_span.Z": "Z"}
ORDER_BOUNDS = (0.25, 3.0)  # measure/richardson.hpp kMinOrder, kMaxOrder


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


def fit(rates, values):
    """Q0 + C r^p by least squares over p within ORDER_BOUNDS: the residual of the linear fit at each p of a grid in
    log p (NumPy, all at once), then SciPy's bounded scalar minimiser around the grid's best: (Q0, C, p)."""
    r, q = np.asarray(rates, dtype=float), np.asarray(values, dtype=float)

    def linear(p):
        x = r[None, :] ** np.atleast_1d(p)[:, None]
        xm, qm = x.mean(axis=1, keepdims=True), q.mean()
        sxx = ((x - xm) ** 2).sum(axis=1)
        c = np.where(sxx > 0, ((x - xm) * (q - qm)).sum(axis=1) / np.where(sxx > 0, sxx, 1), 0.0)
        q0 = qm - c * xm[:, 0]
        return q0, c, ((q - q0[:, None] - c[:, None] * x) ** 2).sum(axis=1)
    lo, hi = np.log(ORDER_BOUNDS)
    grid = np.linspace(lo, hi, 400)
    k = int(np.argmin(linear(np.exp(grid))[2]))
    res = optimize.minimize_scalar(lambda g: linear(np.exp(g))[2][0], method="bounded",
                                   bounds=(grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]),
                                   options={"xatol": 1e-10})
    best = min([res.x, lo, hi], key=lambda g: linear(np.exp(g))[2][0])
    q0, c, _ = linear(np.exp(best))
    return float(q0[0]), float(c[0]), float(np.exp(best))


def simulated_bounds(rates, values, sd, dof, alpha, draws=500, seed=1):
    """The distance's one-sided (1 - alpha) bounds by the same propagation as the code's, with NumPy's own draws."""
    rng = np.random.default_rng(seed)
    q0, c, p = fit(rates, values)
    fitted = q0 + c * np.asarray(rates) ** p
    out = []
    for _ in range(draws):
        s = sd * math.sqrt(dof / rng.chisquare(dof))
        out.append(fit(rates, fitted + s * rng.standard_normal(len(rates)))[1])
    return np.quantile(out, alpha), np.quantile(out, 1 - alpha)


def check_against_oracle(v, simulate=True):
    """Recomputes a test's verify_rate numbers and verdicts from the values it gives."""
    rates = [1.0] + v["rungs"]
    family = sum(1 for c in v["comparisons"].values() if c["verdict"] != "not compared")
    assert v["family"]["quantities"] == family
    verdicts_q = []
    for q, c in v["comparisons"].items():
        if c["verdict"] == "not compared":
            verdicts_q.append("not compared")
            continue
        floor = v["floors"][FLOOR_OF[q]]
        assert c["floor"] == floor
        values = [c["test"]] + c["rungs"]
        q0, dist, p = fit(rates, values)
        if ORDER_BOUNDS[0] * 1.01 < p < ORDER_BOUNDS[1] * 0.99 and v["rungs"] == [0.5, 0.25]:
            # three rates a factor 2 apart: the closed form
            assert p == pytest.approx(math.log2((values[0] - values[1]) / (values[1] - values[2])), rel=1e-6)
        assert c["order"] == pytest.approx(p, rel=1e-4, abs=1e-4), (q, c)
        assert c["error_floors"] == pytest.approx(dist / floor, rel=1e-4, abs=1e-6), (q, c)
        assert c["quasi_static"] == pytest.approx(q0, rel=1e-6, abs=1e-9)
        runs = [c["test"]] + c["twins"]
        assert c["chaos_dof"] == len(runs) - 1
        if len(runs) >= 2:
            assert c["chaos_sd"] == pytest.approx(float(np.std(runs, ddof=1)), rel=1e-9)
        lo, hi = c["bounds95_floors"]
        flo, fhi = c["family_bounds_floors"]
        if c.get("reason"):  # no twins, or twins that did not part: no bounds
            assert lo is None and c["verdict"] == "unresolved"
        else:
            assert flo <= lo <= c["error_floors"] or c["order_at_bound"] or lo <= c["error_floors"]
            if simulate:
                slo, shi = simulated_bounds(rates, values, c["chaos_sd"], c["chaos_dof"], 0.05)
                width = max(hi - lo, 1e-12)
                assert lo == pytest.approx(slo / floor, abs=0.25 * width) and hi == pytest.approx(shi / floor, abs=0.25 * width), \
                    (q, lo, hi, slo / floor, shi / floor)
        T = v["tolerance_floors"]
        expected = ("unresolved" if lo is None else "converged" if lo > -T and hi < T else
                    "not converged" if flo > T or fhi < -T else "unresolved")
        assert c["verdict"] == expected, f"{q}: {c} against {expected}"
        verdicts_q.append(expected)
    overall = ("not converged" if "not converged" in verdicts_q else
               "converged" if verdicts_q and all(t == "converged" for t in verdicts_q) else "unresolved")
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
        check_against_oracle(v, simulate=False)
        assert v["verdict"] != "not converged", f"{test}: at the paper's rate: {v['reason']}"
        assert all(c["verdict"] != "not converged" for c in v["comparisons"].values()), v["comparisons"]


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
        announced = stdout.index(f"{test}: rate check after the test, by a ladder of rates")
        assert announced < stdout.index(f"{test}: done"), "the cost comes before the test is done"
        cost = t["verify_rate"]["cost"]
        assert [c["run"] for c in cost["runs"]] == ["rung 0.5x", "rung 0.25x", "twin 1.001x", "twin 1.002x"]
        for c, name in zip(cost["runs"], ("rung-1", "rung-2", "twin-1", "twin-2")):
            assert f"  {c['run']}: {c['steps']} steps, " in stdout[announced:], stdout[announced:][:600]
            assert c["steps"] == t["verify_rate"]["runs"][name]["steps"], "the predicted steps are run"
        assert f"  in all: {cost['particle_steps']:.3g} particle-steps, about " in stdout[announced:]


def test_the_runs_start_from_the_tests_start_and_leave_its_series_alone(celldem, work, fast):
    fast_deck, summary, _ = fast
    plain = run(celldem, fast_deck, os.path.join(work, "plain"), "--threads", "1")
    for test, t in summary["tests"].items():
        assert read(os.path.join(work, "fast", test, "series.csv")) == \
            read(os.path.join(work, "plain", test, "series.csv")), f"{test}: --verify-rate changed the test's own series"
        assert "verify_rate" not in plain["tests"][test], f"{test}: verify_rate without --verify-rate"
        own = first_row(os.path.join(work, "fast", test, "series.csv"))
        runs = t["verify_rate"]["runs"]
        for name, r in runs.items():
            row = first_row(os.path.join(work, "fast", r["series"]))
            for k in ("step", "e1", "e2", "e3", "s11", "s22", "s33", "ev", "Z"):
                assert row[k] == own[k], f"{test} {name}: first row {k} {row[k]} is not the test's {own[k]}"
            # a run at f times the rate covers the same strain in 1/f of the steps (within a step of each leg's end)
            assert abs(r["steps"] - t["steps"] / r["factor"]) <= 2, (name, r["steps"], t["steps"])


def test_the_check_gives_the_same_bytes_on_two_threads(celldem, work, fast):
    fast_deck, summary, _ = fast
    run(celldem, fast_deck, os.path.join(work, "two"), "--verify-rate", "--threads", "2", "--fixed-threads")
    for test, t in summary["tests"].items():
        for name, r in t["verify_rate"]["runs"].items():
            assert read(os.path.join(work, "fast", r["series"])) == read(os.path.join(work, "two", r["series"])), \
                f"{test} {name}: the series differs between 1 and 2 threads"
    with open(os.path.join(work, "two", "summary.json")) as f:
        two = json.load(f)
    for test, t in summary["tests"].items():
        assert two["tests"][test]["verify_rate"]["comparisons"] == t["verify_rate"]["comparisons"], test


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
            assert v["twins"] == 0 and v["verdict"] in ("unresolved", "not converged"), "no twins: a seed alone is unresolved"
            assert all(c["verdict"] in ("unresolved", "not compared") for c in v["comparisons"].values())
            check_against_oracle(v, simulate=False)
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
    keyed["tests"][1]["verify_rate"] = {"rungs": [0.25, 0.5, 0.125], "twins": 3}
    keyed_deck = os.path.join(work, "keyed.json")
    with open(keyed_deck, "w") as f:
        json.dump(keyed, f)
    by_key = run(celldem, keyed_deck, os.path.join(work, "keyed"), "--threads", "1")
    name0, name1 = keyed["tests"][0]["name"], keyed["tests"][1]["name"]
    assert "verify_rate" not in by_key["tests"][name0], f"{name0}: checked without being asked"
    v = by_key["tests"][name1]["verify_rate"]
    assert v["rungs"] == [0.5, 0.25, 0.125] and v["twins"] == 3 and "twin-3" in v["runs"], v
    check_against_oracle(v)  # four rates: least squares
    for bad_key, named in (({"twin": 3}, "tests[1].verify_rate.twin"), ({"rungs": [0.5]}, "tests[1].verify_rate.rungs"),
                           ({"rungs": [0.5, 1.5]}, "tests[1].verify_rate.rungs[1]"),
                           ({"rungs": [0.5, 0.25], "rate_factor": 0.5}, "tests[1].verify_rate.rate_factor"),
                           ({"twins": 1}, "tests[1].verify_rate.twins")):
        keyed["tests"][1]["verify_rate"] = bad_key
        with open(keyed_deck, "w") as f:
            json.dump(keyed, f)
        bad = subprocess.run([celldem, "check", keyed_deck], capture_output=True, text=True)
        assert bad.returncode == 2 and named in bad.stderr, \
            f"{bad_key}: exit 2 naming {named}, got {bad.returncode}: {bad.stderr}"
    for rungs in ("0.5", "0.5,abc", "0.5,0.5", "0.5,0"):
        bad = subprocess.run([celldem, "run", fast_deck, "--out", os.path.join(work, "bad"), "--verify-rate",
                              "--verify-rate-rungs", rungs], capture_output=True, text=True)
        assert bad.returncode == 2 and "--verify-rate-rungs" in bad.stderr, (rungs, bad.returncode, bad.stderr)
    bad = subprocess.run([celldem, "run", fast_deck, "--out", os.path.join(work, "bad"), "--verify-rate", "--floors",
                          os.path.join(ROOT, "tests", "run", "small_run.json")], capture_output=True, text=True)
    assert bad.returncode == 2 and "ratio13" in bad.stderr, \
        f"a floors file without floors: exit 2 naming the key, got {bad.returncode}: {bad.stderr}"


def test_a_tolerance_run_prints_its_tolerance_cost_distance_and_verdicts(celldem, work):
    """`--tolerance 3 --verify-rate`: the run prints the tolerance it applied, what it costs against the deck as
    written, the inertial number the rate bias laws allow and how far the written deck is from I -> 0 before it
    starts, and each rate-check verdict after each test; summary.json holds the same (its tolerance block as
    `celldem plan --tolerance 3 --json` gives it)."""
    deck = deck_at(paper_increment(), work, "tolerance")
    summary, stdout = run(celldem, deck, os.path.join(work, "tolerance"), "--tolerance", "3", "--verify-rate",
                          "--no-verify-twin", "--threads", "1", quiet=False)
    plan = json.loads(subprocess.run([celldem, "plan", deck, "--tolerance", "3", "--json"], capture_output=True,
                                     text=True, check=True).stdout)["tolerance"]
    t = summary["tolerance"]
    assert t["total"] == plan["total"] and t["tolerance"] == 3 and t["rate"] == plan["rate"]
    cost = 1 / t["total"]["ratio_low"]
    first = stdout.splitlines()[0]
    assert first.startswith("tolerance 3 noise floors from I -> 0") and f"{cost:.3g}x the deck's cost" in first, first
    rate = t["rate"]
    assert f"strain-driven legs at actual inertial number {rate['inertial_number']:.3g}" in stdout
    for w in rate["written"]:
        assert f"{w['stage']} as written: I {w['inertial_number']:.3g}, " in stdout
        assert w["slowed"] == (w["inertial_number"] > rate["inertial_number"])
    assert "promise: the mean over seeds" in stdout and "one run adds" in rate["promise"]
    for test, s in summary["tests"].items():
        v = s["verify_rate"]
        assert v["tolerance_floors"] == 3
        assert f"{test}: rate check: {v['verdict']}: " in stdout
        for q, c in v["comparisons"].items():
            line = f"{test}:   {q}: not compared" if c["verdict"] == "not compared" else f"{test}:   {q:<20s} "
            assert line in stdout and c["verdict"] in stdout, (line, stdout[-1500:])
    # The promise against the run: the mean actual inertial number of each test's strain-driven rows, recomputed
    # from its series, each law's distance at it, and the verdict on the console.
    legs = {leg["path"] for stage in t["stages"] for leg in stage["legs"] if "path" in leg}
    assert legs == {"axial", "plane strain"}, legs
    for test, s in summary["tests"].items():
        k = s["tolerance"]
        with open(os.path.join(work, "tolerance", test, "series.csv")) as f:
            rows = [r for r in csv.DictReader(f) if float(r["step"]) > 0 and float(r["imposed_inertial_number"]) > 0]
        actual = np.mean([float(r["inertial_number"]) for r in rows])
        imposed = np.mean([float(r["imposed_inertial_number"]) for r in rows])
        assert math.isclose(k["inertial_number"], actual, rel_tol=1e-6), (k, actual)
        assert math.isclose(k["actual_to_imposed"], actual / imposed, rel_tol=1e-6)
        assert k["inertial_number_allowed"] == rate["inertial_number"]
        assert k["kept"] == all(u <= 3 * (1 + 1e-9) for _, u in k["distance_floors"].values())
        assert set(k["distance_floors"]) == {law["quantity"] for law in rate["laws"]}
        assert f"{test}: tolerance 3 floors {'kept' if k['kept'] else 'NOT kept'}: " in stdout, stdout[-1500:]
