"""tools/report.py on small real runs (tests/run/small_run.json, 150 spheres, a few seconds each): a
preparation-only run, a graded preparation, tests under arbitrary names, a constant-b (failure-surface) deck, a
3-seed ensemble, tests with stress and strain probes; and the force-chain slab on a hand-made contact list."""

import json
import os
import re
import subprocess

import numpy as np
import pytest

from celldem import probes, results
from celldem.reports import ensemble_report, figures, force_chains, plotting
from checking import ROOT, check, is_png, read_text, tool

SMALL_RUN = os.path.join(ROOT, "tests", "run", "small_run.json")


def small_deck(tests, **changes):
    """small_run.json with its tests replaced by `tests` (the preparation kept), and top-level keys changed."""
    with open(SMALL_RUN) as f:
        deck = json.load(f)
    deck["tests"] = tests
    deck.update(changes)
    return deck


def run_deck(celldem, folder, deck, *options):
    """Writes the deck into folder/deck.json, runs it into folder/run (one thread, quiet); returns the run folder."""
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "deck.json")
    with open(path, "w") as f:
        json.dump(deck, f)
    out = os.path.join(folder, "run")
    r = subprocess.run([celldem, "run", path, "--out", out, *options, "--quiet", "--threads", "1"],
                       capture_output=True, text=True)
    assert r.returncode == 0, f"celldem run {path} {' '.join(options)}: exit {r.returncode}: {r.stderr.strip()}"
    return out


def section_heading(text, heading):
    return re.search(r"^##.*" + re.escape(heading), text, re.M) is not None


def assert_figure_in_report(run_dir, stem, text):
    assert is_png(os.path.join(run_dir, "figures", stem + ".png")), f"{stem}.png: no PNG"
    assert f"](figures/{stem}.png)" in text, f"{stem} not in the report"


@pytest.fixture(scope="module")
def prep(tmp_path_factory, celldem):
    """A preparation-only run and its report."""
    run_dir = run_deck(celldem, tmp_path_factory.mktemp("prep"), small_deck([]))
    tool("report", run_dir)
    return run_dir


def test_preparation_only_run(prep):
    """Preparation figures and values, no paper table, no test table."""
    r = read_text(os.path.join(prep, "report.md"))
    assert_figure_in_report(prep, "prepare", r)
    assert re.search(r"^\| void ratio e \(–\) \| 0\.[0-9]* \|", r, re.M), "no prepared void ratio"
    for heading in ("Comparison with the paper", "Per-test values", "Tests compared"):
        assert not section_heading(r, heading), f"preparation-only run: section '{heading}'"
    assert "n/a" not in r, "preparation-only run: n/a in the report"
    assert not re.search(r"^## Grading", r, re.M), "a listed sample's report has a Grading section"


def test_graded_preparation(tmp_path, celldem):
    """The report's grading table is summary.json's, row by row."""
    deck = small_deck([])
    deck["sample"]["diameters"] = {"grading": {"by": "mass", "sizes": [0.003, 0.0036, 0.0045],
                                               "passing": [0, 30, 100]}}
    run_dir = run_deck(celldem, tmp_path, deck)
    tool("report", run_dir)
    g = json.load(open(os.path.join(run_dir, "summary.json")))["grading"]
    text = read_text(os.path.join(run_dir, "report.md"))
    assert "## Grading" in text, "no Grading section"
    for size, asked, realised in zip(g["sizes_m"], g["asked_percent"], g["realised_percent"]):
        row = f"| {size * 1e3:.4g} | {asked:.2f} | {realised:.2f} |"
        assert row in text, f"no row {row}"
    assert f"largest deviation {g['largest_deviation_percent']:.2f} percentage points" in text, "no largest deviation"


NAMED_TESTS = [
    {"name": "Squash-A", "friction": 0.5,
     "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "strain": 0.006}, "output_interval": 250},
    {"name": "flat_2", "friction": 0.5,
     "axes": {"x1": {"strain_increment": 1e-6}, "x2": {"strain_increment": 0}, "x3": {"stress": 1e5}},
     "end": {"axis": "x1", "strain": 0.006}, "output_interval": 250}]


@pytest.fixture(scope="module")
def named(tmp_path_factory, celldem):
    run_dir = run_deck(celldem, tmp_path_factory.mktemp("named"), small_deck(NAMED_TESTS))
    tool("report", run_dir)
    return run_dir


def test_arbitrarily_named_tests(named):
    """A figure per test, force chains, no paper table."""
    r = read_text(os.path.join(named, "report.md"))
    for t in ("Squash-A", "flat_2"):
        assert_figure_in_report(named, f"test_{t}", r)
    assert_figure_in_report(named, "force_chains", r)
    assert re.search(r"^## Force chains", r, re.M), "no force-chain section"
    assert "Comparison with the paper" not in r, "a paper table for a deck that is not the paper's"
    assert not re.search(r"^## Failure surface", r, re.M), "failure surface for a deck without b tests"


def test_named_run_per_test_table(named):
    """The per-test table leads and carries no row that is n/a for every test."""
    text = read_text(os.path.join(named, "report.md"))
    table = [line for line in text.split("## Per-test values", 1)[1].split("\n## ", 1)[0].splitlines()
             if line.startswith("| ")]
    assert table and "Squash-A" in table[0] and "flat_2" in table[0], f"per-test table header: {table[:1]}"
    for row in table[1:]:
        cells = [c.strip() for c in row.strip("|").split("|")][1:]
        assert not all(c == "n/a" for c in cells), f"row of n/a: {row}"
    n_a = text.count("n/a")
    assert n_a <= 3, f"{n_a} n/a in the report"


def constant_b_test(name, b):
    return {"name": name, "friction": 0.5,
            "axes": {"x1": {"strain_increment": 2e-6}, "x2": {"b": b}, "x3": {"mean_stress": 1e5}},
            "end": {"axis": "x1", "strain": 0.04}, "output_interval": 250}


def test_constant_b_deck(tmp_path, celldem):
    """The failure surface's table and pi-plane figure in the report."""
    tests = [constant_b_test("b0", 0.0), constant_b_test("b50", 0.5), constant_b_test("b100", 1.0)]
    run_dir = run_deck(celldem, tmp_path, small_deck(tests))
    tool("report", run_dir)
    r = read_text(os.path.join(run_dir, "report.md"))
    assert re.search(r"^## Failure surface", r, re.M), "no failure-surface section"
    assert re.search(r"^\| Matsuoka-Nakai \| ", r, re.M), "no criterion table"
    for t in ("b0", "b50", "b100"):
        assert re.search(rf"^\| {t} \| ", r, re.M), f"failure surface: no row of {t}"
    for f in ("failure_surface_pi_plane", "failure_surface_phi_b"):
        assert_figure_in_report(run_dir, f, r)


@pytest.fixture(scope="module")
def ensemble(tmp_path_factory, celldem):
    """A 3-seed ensemble of small_run.json, its tests run to 4 %, past their peaks (a peak at a test's end is left
    out of the statistics), and its report with the paper's comparison."""
    with open(SMALL_RUN) as f:
        text = f.read()
    assert '"strain":0.006' in text, "small_run.json's tests no longer end at \"strain\":0.006"
    deck = json.loads(text.replace('"strain":0.006', '"strain":0.04'))
    run_dir = run_deck(celldem, tmp_path_factory.mktemp("ens"), deck, "--seeds", "1-3")
    tool("report", run_dir, "--paper")
    return run_dir


def test_ensemble_figures(ensemble):
    r = read_text(os.path.join(ensemble, "report.md"))
    for f in ("test_ttc", "test_psc", "fig02_stress_ratio", "overview", "prepare", "force_chains"):
        assert_figure_in_report(ensemble, f, r)


def test_ensemble_report_statistics(ensemble):
    """Band figures, statistics from ensemble.json, statistical verdicts."""
    ens = results.load_run_or_report(ensemble, "test")
    stats = json.load(open(os.path.join(ensemble, "ensemble.json")))
    text = read_text(os.path.join(ensemble, "report.md"))
    check("seed runs loaded", len(ens.runs), 3)
    assert "band ± 1 standard deviation" in text, "the report does not say what the band is"
    # Per-test and paired numbers are ensemble.json's; the tests' columns in the deck's order (ttc, then psc).
    check("tests in the deck's order", ens.test_names, ["ttc", "psc"])
    cells = [f"{p['mean']:.3f} ± {p['std']:.3f} [{p['ci95'][0]:.3f}, {p['ci95'][1]:.3f}]"
             for p in (stats["tests"][t]["peak_ratio13"] for t in ens.test_names)]
    assert f"| peak σ1/σ3 (–) | {' | '.join(cells)} |" in text, "per-test peak is not ensemble.json's"
    diff = stats["paired"]["ttc-psc"]["peak_ratio13"]
    row = next((line for line in text.splitlines() if line.startswith("| peak σ1/σ3 (–) | ttc − psc |")), None)
    assert row is not None and f"{diff['mean']:.3f} ± {diff['std']:.3f}" in row, \
        f"paired difference is not ensemble.json's: {row}"
    lo, hi = diff["ci95"]
    # A difference called after Holm's adjustment is called without it too: its 95 % interval excludes 0; one whose
    # printed (unadjusted) interval excludes 0 without a call says so.
    outside = "not distinguishable at 3 seeds" + ensemble_report.ADJUSTED_NOTE.format("0", "95 % interval")
    allowed = (["ttc lower than psc", outside] if hi < 0 else ["ttc higher than psc", outside] if lo > 0 else
               ["not distinguishable at 3 seeds"])
    assert any(row.rstrip(" |").endswith(w) for w in allowed), f"paired verdict: want one of {allowed} in {row}"
    assert "Holm" in row, f"the paired verdict does not give its Holm-adjusted p: {row}"
    assert "family-wise error rate of 5 %" in text, "the report does not state its family-wise error rate"
    # The paper's findings judged statistically, naming the test used.
    paper = text.split("## Comparison with the paper", 1)[-1].split("\n## ", 1)[0]
    rows = [line for line in paper.splitlines() if line.startswith("| ") and not line.startswith("| Finding")]
    assert len(rows) >= 10, f"{len(rows)} findings judged"
    assert any("paired t" in line for line in rows) and any("one-sample t" in line for line in rows), \
        "the findings do not name their tests"
    verdict = (r"\| (yes|no[^|]*|\*\*no\*\*[^|]*|not distinguishable at 3 seeds[^|]*|consistent[^|]*|equivalent|"
               r"different[^|]*|undecided at 3 seeds[^|]*|by construction[^|]*) \|$")
    without = [line for line in rows if not re.search(verdict, line)]
    assert not without, "a finding without a verdict: " + (without[0] if without else "")
    assert any("prediction interval" in line for line in rows) and any("TOST, margin" in line for line in rows), \
        "the paper's values are not judged by prediction intervals, or sameness not by TOST"
    prep = stats["prepared"]["void_ratio"]
    assert any(line.startswith("| Prepared void ratio e | 0.570 | " + f"{prep['mean']:.3f} ± {prep['std']:.3f}")
               for line in rows), "prepared void ratio is not ensemble.json's"


def test_ensemble_figure_curves_have_bands(ensemble):
    """Every curve of an ensemble figure is a mean with a band."""
    ens = results.load_run_or_report(ensemble, "test")
    plt = plotting.pyplot()
    entry = next(p for p in figures.plan(ens, True) if p.stem == "fig02_stress_ratio")
    fig = entry.make(plt)
    ax = fig.axes[0]
    assert (len(ax.collections), len(ax.lines)) == (2, 2), \
        f"stress ratio of an ensemble: {len(ax.collections)} bands, {len(ax.lines)} lines (want 2 and 2)"


def test_probes_of_a_real_run(tmp_path, celldem):
    """Stress probes in the π plane (a point not reached, and no peak in 0.6 % of strain) and strain probes: the
    report reads celldem's own probes.csv and stiffness.json, quotes summary.json's statuses and reasons, lists the
    stiffness diagonals as stiffness.json holds them, and draws both figures."""
    deck = small_deck(json.load(open(SMALL_RUN))["tests"])
    deck["tests"][0]["probes"] = {"at_e1": [0.002, 0.05], "at": ["peak"], "kind": "stress", "plane": "pi",
                                  "directions": 6, "magnitudes": [2000], "steps": 500, "hold_steps": 200}
    deck["tests"][1]["probes"] = {"at_e1": [0.002], "kind": "strain", "magnitudes": [1e-5], "steps": 500,
                                  "hold_steps": 200}
    run_dir = run_deck(celldem, tmp_path, deck)
    tool("report", run_dir)
    text = read_text(os.path.join(run_dir, "report.md"))
    assert section_heading(text, "Probes"), "no Probes section"
    summary = json.load(open(os.path.join(run_dir, "summary.json")))["tests"]
    ttc = probes.load(results.load_run(run_dir), "ttc")
    assert len(ttc.point_rows("e1_0.002")) == 6 and all(probes.is_ok(r) for r in ttc.point_rows("e1_0.002")), \
        "probes.csv of the stress probes not read as six probes that ran"
    assert "| e1_0.002 | 0.200 | 2000 | ran | 6 / 6 / 0 |" in text
    for point in ("e1_0.05", "peak"):
        entry = summary["ttc"]["probes"]["points"][point]
        assert entry["status"] == "not run"
        assert f"| {point} | — | — | **not run** | — | n/a | — | {entry['reason']} |" in text, f"no row for {point}"
    assert "- e1_0.002, M = 2 kPa: the largest total response is along d0" in text, "no envelope findings"
    magnitude = json.load(open(os.path.join(run_dir, "psc", "probes", "stiffness.json")))["points"]["e1_0.002"][
        "magnitudes"][0]
    for kind in ("elastic", "tangent"):
        diagonal = " | ".join(f"{magnitude[kind][i][i] * 1e-6:.4g}" for i in range(6))
        assert f"| {kind} | {diagonal} |" in text, f"the {kind} stiffness's diagonal is not stiffness.json's"
    for stem in ("probe_envelopes", "probe_stiffness_psc"):
        assert_figure_in_report(run_dir, stem, text)


def test_force_chain_slab():
    """Strong contacts only, the particle inside the slab, periodic images."""
    h = np.diag([0.01, 0.01, 0.01])
    xi = np.array([[0.005, 0.005, 0.005],    # in the slab (x2 = 5 mm): kept, from i
                   [0.005, 0.0001, 0.005],   # i below the slab; j = i + branch wraps into it: kept, from j
                   [0.002, 0.005, 0.002],    # in the slab but weak: left out
                   [0.002, 0.009, 0.002]])   # neither end in the slab: left out
    branch = np.array([[0.003, 0.0, 0.0], [0.0, -0.0052, 0.001], [0.003, 0.0, 0.0], [0.003, 0.0, 0.0]])
    force = np.array([10.0, 8.0, 1.0, 9.0])  # mean 7
    start, end, f = force_chains.slab_segments(xi, branch, force, h, thickness=0.0015)
    check("contacts in the slab", len(f), 2)
    check("forces", list(f), [10.0, 8.0])
    assert np.allclose(start[0], xi[0]) and np.allclose(end[0], xi[0] + branch[0]), \
        "contact with i in the slab not drawn from i"
    assert np.allclose(start[1], [0.005, 0.0049, 0.006]) and np.allclose(end[1] - start[1], -branch[1]), \
        f"contact across the boundary not drawn from j's wrapped centre: {start[1]} -> {end[1]}"


def test_force_chain_title_names_the_driven_measure():
    """A shear test's peak network is titled with its own measure and strain (peak_contacts.json), not s1/s3."""
    shear = {"measure": "|s12|/s22", "value": 0.41, "g12": 0.113, "e1": 0.0, "ratio13": 1.42, "step": 5, "cell": []}
    assert force_chains.peak_words(shear) == "peak |s12|/s22 0.41 at g12 = 11.30 %"
    axial = {"e1": 0.0186, "ratio13": 2.9368, "step": 5, "cell": []}
    assert force_chains.peak_words(axial) == "peak σ1/σ3 2.94 at ε1 = 1.86 %"
