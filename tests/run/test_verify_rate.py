"""`celldem run --verify-rate` on a small deck (tests/run/small_run.json, 150 spheres, tests to 3 % of axial
strain: past their peaks) at two driving rates, the paper's strain increment (inputs/paper.json's tests) and a
hundred times it:

- at the paper's rate no checked point is "not converged" and every point that a branch checked is
  "converged" (within 1 noise floor);
- the run a hundred times too fast (inertial number near 1e-2, which the run warns of) is flagged: at least one
  point is "not converged" (beyond the tolerance plus the chaos margin of one pair of runs);
- the test's own series are the bytes of a run without --verify-rate (the branches leave them alone), the
  branches' series exist where summary.json says, each branch starts from the test's own state (its first row is
  the test's row of that step, every column but the centred dilatancy index, which depends on the rows around
  it), and a branch gives the same bytes on one thread and on two;
- a test's verify_rate key asks for the check of that test alone, with its points and window, and a bad value of
  it or a floors file without floors is refused with exit 2 naming the key.

Ten times the paper's rate is not enough on 150 spheres: its branches differ from the test by no more than the
paper-rate run's (chaos, not the rate, sets the difference at this size), so the verdict there is honest about it
rather than flagged. About 30 s of CPU.

Usage: CELLDEM=build/celldem /usr/bin/python3 -m pytest tests/run/test_verify_rate.py (ctest: run_verify_rate)
"""
import csv
import json
import os
import subprocess

import pytest

pytestmark = pytest.mark.slow

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
END_STRAIN = 0.03
STRAIN_PER_ROW = 2.5e-4  # the same rows per strain at every rate (a peak's row sampling does not change)


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


def run(celldem, deck, out, *extra):
    result = subprocess.run([celldem, "run", deck, "--out", out, "--quiet", *extra], capture_output=True, text=True)
    assert result.returncode == 0, f"{deck} {extra}: exit {result.returncode}: {result.stderr[-2000:]}"
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def verdicts(summary):
    return {(test, point): p["verdict"] for test, t in summary["tests"].items()
            for point, p in t["verify_rate"]["points"].items()}


def read(path):
    with open(path, "rb") as f:
        return f.read()


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return str(tmp_path_factory.mktemp("verify_rate"))


@pytest.fixture(scope="module")
def fast(celldem, work):
    """The deck a hundred times the paper's rate, and its run with --verify-rate on one thread."""
    deck = deck_at(100 * paper_increment(), work, "too_fast")
    return deck, run(celldem, deck, os.path.join(work, "fast"), "--verify-rate", "--threads", "1")


def test_at_the_papers_rate_every_point_converges(celldem, work):
    slow = run(celldem, deck_at(paper_increment(), work, "paper_rate"), os.path.join(work, "paper"), "--verify-rate",
               "--threads", "1")
    v = verdicts(slow)
    assert len(v) == 4, f"two points of two tests checked, got {v}"
    # A test whose s11/s33 is largest at its last row has no peak to check (summary.json peak_reached).
    for (test, point), x in v.items():
        no_peak = point == "peak" and not slow["tests"][test]["peak_reached"]
        assert x == ("not checked" if no_peak else "converged"), \
            f"at the paper's rate every point converges, a peak that is the last row is not checked: {v}"
    assert list(v.values()).count("converged") >= 3, f"at least three points checked and converged: {v}"


def test_a_run_too_fast_is_flagged_and_its_branches_start_from_the_test(work, fast):
    _, summary = fast
    v = verdicts(summary)
    assert "not converged" in v.values(), f"a run 100 x too fast has a point not converged: {v}"
    assert not all(t["controlled"] for t in summary["tests"].values()), "a run 100 x too fast: its servo cannot hold x2, x3"
    for test, t in summary["tests"].items():
        for point, p in t["verify_rate"]["points"].items():
            if p["verdict"] == "not checked":
                assert point == "peak" and not t["peak_reached"], f"{test} {point}: not checked: {p.get('reason')}"
                continue
            branch_path = os.path.join(work, "fast", p["series"])
            assert os.path.isfile(branch_path), f"{test} {point}: {p['series']} missing"
            with open(branch_path) as f:
                first = next(csv.DictReader(f))
            with open(os.path.join(work, "fast", test, "series.csv")) as f:
                parent = {row["step"]: row for row in csv.DictReader(f)}
            same = parent.get(first["step"])
            assert same is not None and all(same[k] == x for k, x in first.items() if k != "DI"), \
                f"{test} {point}: the branch's first row (step {first['step']}) is not the test's row there"
            window = p["window"]
            assert abs(window["to_strain"] - window["from_strain"]) >= t["verify_rate"]["window_strain"] - 1e-12, \
                f"{test} {point}: the branch spans a whole window: {window}"


def test_rows_coarser_than_the_compared_span_still_count(celldem, work, fast):
    """Rows farther apart than the compared span (a quarter of the window): the span holds only the point's own
    row, whose strain the rows keep to 10 digits; it must still count (it was once missed by round-off, and the
    check then compared two empty means, zeros, and called the point converged). A quantity that cannot be
    compared never makes a point converged."""
    fast_deck, _ = fast
    with open(fast_deck) as f:
        coarse = json.load(f)
    for test in coarse["tests"]:  # (strains with more than 10 digits: 100/7 x the paper's increment, rows every 701 steps)
        test["axes"]["x1"]["strain_increment"] = 100 * paper_increment() / 7
        test["output_interval"] = 701
    coarse_deck = os.path.join(work, "coarse.json")
    with open(coarse_deck, "w") as f:
        json.dump(coarse, f)
    sparse = run(celldem, coarse_deck, os.path.join(work, "coarse"), "--verify-rate", "--threads", "1")
    compared = [(test, point, p) for test, t in sparse["tests"].items() for point, p in t["verify_rate"]["points"].items()
                if "end_means" in p.get("window", {})]
    assert len(compared) >= 3, f"coarse rows: at least three points branched, got {len(compared)}"
    for test, point, p in compared:
        means = p["window"]["end_means"]
        assert means["parent_rows"] >= 1 and means["branch_rows"] >= 1, \
            f"coarse rows, {test} {point}: the point's own row is in the compared span: {means}"
        assert "not_compared" not in p or p["verdict"] != "converged", \
            f"coarse rows, {test} {point}: converged without comparing {p.get('not_compared')}"


def test_the_branches_leave_the_series_alone(celldem, work, fast):
    fast_deck, summary = fast
    plain = run(celldem, fast_deck, os.path.join(work, "plain"), "--threads", "1")
    for test in summary["tests"]:
        assert read(os.path.join(work, "fast", test, "series.csv")) == \
            read(os.path.join(work, "plain", test, "series.csv")), f"{test}: --verify-rate changed the test's own series"
        assert "verify_rate" not in plain["tests"][test], f"{test}: verify_rate without --verify-rate"


def test_a_branch_gives_the_same_bytes_on_two_threads(celldem, work, fast):
    fast_deck, summary = fast
    run(celldem, fast_deck, os.path.join(work, "two"), "--verify-rate", "--threads", "2", "--fixed-threads")
    for test, t in summary["tests"].items():
        for point, p in t["verify_rate"]["points"].items():
            if "series" not in p:  # (not checked: no branch)
                continue
            assert read(os.path.join(work, "fast", p["series"])) == read(os.path.join(work, "two", p["series"])), \
                f"{test} {point}: the branch's series differs between 1 and 2 threads"


def test_the_deck_key_asks_for_one_test_and_bad_values_are_refused(celldem, work, fast):
    fast_deck, _ = fast
    with open(fast_deck) as f:
        keyed = json.load(f)
    keyed["tests"][1]["verify_rate"] = {"at": ["end"], "window_strain": 0.004}
    keyed_deck = os.path.join(work, "keyed.json")
    with open(keyed_deck, "w") as f:
        json.dump(keyed, f)
    by_key = run(celldem, keyed_deck, os.path.join(work, "keyed"), "--threads", "1")
    name0, name1 = keyed["tests"][0]["name"], keyed["tests"][1]["name"]
    assert "verify_rate" not in by_key["tests"][name0], f"{name0}: checked without being asked"
    assert list(by_key["tests"][name1]["verify_rate"]["points"]) == ["end"] and \
        by_key["tests"][name1]["verify_rate"]["window_strain"] == 0.004, f"{name1}: the key's points and window"
    keyed["tests"][1]["verify_rate"] = {"at": ["middle"]}
    with open(keyed_deck, "w") as f:
        json.dump(keyed, f)
    bad = subprocess.run([celldem, "check", keyed_deck], capture_output=True, text=True)
    assert bad.returncode == 2 and "tests[1].verify_rate.at[0]" in bad.stderr, \
        f"an unknown point: exit 2 naming the key, got {bad.returncode}: {bad.stderr}"
    bad = subprocess.run([celldem, "run", fast_deck, "--out", os.path.join(work, "bad"), "--verify-rate", "--floors",
                          os.path.join(ROOT, "tests", "run", "small_run.json")], capture_output=True, text=True)
    assert bad.returncode == 2 and "ratio13" in bad.stderr, \
        f"a floors file without floors: exit 2 naming the key, got {bad.returncode}: {bad.stderr}"
