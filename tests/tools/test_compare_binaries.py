"""tools/compare_binaries.py (tools/celldem/performance/paired.py): the verdict against SciPy's t interval computed
independently, its three outcomes and the bar, its refusals; the command line's refusals; then, where the build's
binary and a small prepared sample exist, two real rounds of the binary against itself (a few seconds): both
rates, the halves, the interval around the mean, and the verdict file not overwritten; then two rounds of whole
processes of a small deck."""

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats

from celldem.performance import paired
from checking import ROOT, tool


def test_the_interval_is_the_t_interval_of_the_log_ratios():
    ratios = [1.10, 1.07, 1.12, 1.09, 1.08, 1.11]
    logs = np.log(ratios)
    half = stats.t.ppf(0.975, len(logs) - 1) * logs.std(ddof=1) / math.sqrt(len(logs))
    v = paired.judge(ratios)
    assert v.low == pytest.approx(math.exp(logs.mean() - half), rel=1e-12)
    assert v.high == pytest.approx(math.exp(logs.mean() + half), rel=1e-12)
    assert v.mean == pytest.approx(math.exp(logs.mean()), rel=1e-12)
    assert v.median == pytest.approx(1.095)
    assert v.verdict == "faster" and v.clears_bar, v.text()
    assert "t-test" in v.text() and "95 %" in v.text() and "5 % bar" in v.text()


def test_the_verdicts_slower_within_noise_and_below_the_bar():
    assert paired.judge([0.88, 0.89, 0.90, 0.885]).verdict == "slower"
    noisy = paired.judge([0.95, 1.06, 1.01, 0.97])
    assert noisy.verdict == "within noise" and not noisy.clears_bar
    small = paired.judge([1.021, 1.019, 1.020, 1.022])
    assert small.verdict == "faster" and not small.clears_bar  # faster, but by about 2 %: below the 5 % bar
    same = paired.judge([1.0, 1.0, 1.0])
    assert same.low == same.high == 1.0 and same.verdict == "within noise"


def test_a_verdict_refuses_too_few_rounds_and_impossible_ratios():
    with pytest.raises(ValueError, match="at least two rounds"):
        paired.judge([1.1])
    for bad in ([1.0, 0.0], [1.0, -1.0], [1.0, float("nan")], [1.0, float("inf")]):
        with pytest.raises(ValueError, match="finite and positive"):
            paired.judge(bad)


def test_the_command_refuses_bad_input(tmp_path):
    exe = sys.executable
    cases = [
        ([str(tmp_path / "missing"), exe], "no executable old binary"),
        ([exe, exe, "--rounds", "1", "--state", exe, "--deck", exe], "--rounds must be at least 2"),
        ([exe, exe, "--state", str(tmp_path / "none.state"), "--deck", exe], "no state at"),
        ([exe, exe, "--state", exe, "--deck", exe, "--bar", "0"], "--bar must be positive"),
    ]
    for args, message in cases:
        r = tool("compare_binaries", *args, check=False)
        assert r.returncode == 2 and message in r.stderr, (args, r.stderr)


def test_a_binary_against_itself_is_neither_faster_nor_slower(tmp_path):
    celldem = os.path.join(ROOT, "build", "celldem")
    if not os.access(celldem, os.X_OK):
        pytest.skip("no build/celldem")
    if len(os.sched_getaffinity(0)) < 2:
        pytest.skip("paired rounds need two cores")
    # A small prepared sample of its own: the small run deck's preparation.
    run = tmp_path / "small"
    deck = os.path.join(ROOT, "tests", "run", "small_run.json")
    subprocess.run([celldem, "run", deck, "--out", str(run), "--threads", "1"], check=True, capture_output=True)
    out = tmp_path / "verdict.json"
    r = tool("compare_binaries", celldem, celldem, "--rounds", 2, "--steps", 300, "--warmup", 50,
             "--deck", deck, "--state", run / "prepared.state", "--json", out)
    v = json.loads(out.read_text())
    assert len(v["rounds_detail"]) == 2 and all(d["old"] > 0 and d["new"] > 0 for d in v["rounds_detail"])
    for d in v["rounds_detail"]:  # the round's ratio is the geometric mean of its halves'
        assert d["ratio"] == pytest.approx(math.sqrt(d["first_half"] * d["second_half"]), rel=1e-12)
    low, high = v["interval_95"]
    assert low <= v["geometric_mean"] <= high and "t-test" in v["test"]
    assert "round 2/2" in r.stdout and "95 % interval" in r.stdout
    r = tool("compare_binaries", celldem, celldem, "--rounds", 2, "--deck", deck, "--state", run / "prepared.state",
             "--json", out, check=False)
    assert r.returncode == 2 and "exists" in r.stderr
    # Whole processes: the small deck run from scratch by both binaries at once, each timed by its own wall clock.
    whole = tmp_path / "whole.json"
    r = tool("compare_binaries", celldem, celldem, "--whole-process", "--rounds", 2, "--deck", deck, "--json", whole)
    w = json.loads(whole.read_text())
    assert w["whole_process"] and "processes/s" in r.stdout
    halves = [d[k] for d in w["rounds_detail"] for k in ("first_half", "second_half")]
    assert all(0.2 < h < 5.0 for h in halves), halves
    assert all(d["old"] > 0 and d["new"] > 0 for d in w["rounds_detail"])

