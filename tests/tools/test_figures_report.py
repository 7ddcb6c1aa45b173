"""tools/figures.py and tools/report.py on synthetic run directories (make_fake_run.py): the figures are written,
the report's comparison table holds the numbers built into the fake data, the report quotes summary.json's
quantities rather than recomputing them (the fake runs' summaries come from `celldem summarize`), and
`celldem summarize` takes s11/s33 for a series without ratio13 (LAMMPS/LIGGGHTS series)."""

import glob
import json
import os
import re
import shutil
import tempfile
import time

import pytest

from celldem import binary, results
from celldem.reports import plotting
from checking import is_png, read_text, tool

FIGURE_PREFIXES = [f"fig{n:02d}_" for n in range(2, 13)]


def check_pngs(folder):
    """The paper's Figures 2-12 and the overview, each one PNG."""
    found = []
    for prefix in FIGURE_PREFIXES:
        matches = glob.glob(os.path.join(folder, prefix + "*.png"))
        assert matches, f"missing figure {prefix}*.png in {folder}"
        found += matches
    found.append(os.path.join(folder, "overview.png"))
    for f in found:
        assert is_png(f), f"missing or empty figure, or not a PNG: {f}"
    assert len(found) == 12, f"expected 12 figures in {folder}, found {len(found)}"


def check_report(run_dir):
    """report.md against expected.json. "alike" runs agree with the paper; in "diverging" ones the fake PSC
    differs from TTC, so each comparison between the tests must say "no" (expected.json says which)."""
    expected = json.load(open(os.path.join(run_dir, "expected.json")))
    text = read_text(os.path.join(run_dir, "report.md"))
    errors = []

    # The first Markdown table of the report, rows keyed by their first cell.
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = {}
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)[1:-1]]
        rows[cells[0]] = cells

    def expect(row, column, wanted, how="equals"):
        got = rows.get(row, [None] * 5)[column]
        ok = got == wanted if how == "equals" else (got is not None and got.startswith(wanted))
        if not ok:
            errors.append(f"row {row!r} column {column}: expected {how} {wanted!r}, got {got!r}")

    RUN, MATCH = 2, 3
    expect("Prepared void ratio e", RUN, f"{expected['prepared_void_ratio']:.3f}")
    expect("Prepared coordination number Z", RUN, f"{expected['prepared_Z']:.2f}")
    expect("PSC b at peak σ1/σ3", RUN, f"{expected['psc_b_at_peak']:.3f}")
    expect("PSC b at peak σ1/σ3", MATCH, "yes")
    expect("PSC b at ε1 = 10 %", RUN, f"{expected['psc_b_at_10']:.3f}")
    peaks = expected["peaks"]

    def yn(flag):
        return "yes" if flag else "no"
    expect("PSC peak σ1/σ3 exceeds TTC's", RUN,
           f"{yn(expected['psc_peak_exceeds_ttc'])} (psc {peaks['psc']:.3f}, ttc {peaks['ttc']:.3f})")
    expect("PSC peak σ1/σ3 exceeds TTC's", MATCH, yn(expected["psc_peak_exceeds_ttc"]))
    fab = expected["fabric_peak"]
    expect("H11/H33 grows more in PSC", RUN, f"yes (max psc {fab['psc']:.3f}, ttc {fab['ttc']:.3f})")
    for row, key in (("Z evolves alike in TTC and PSC", "z_alike"),
                     ("Sliding fraction evolves alike in TTC and PSC", "sliding_alike"),
                     ("σ1/σ3 vs Hs11/Hs33 (ε1 ≤ 1 %) is one curve for both tests", "macro_micro_unique")):
        expect(row, RUN, yn(expected[key]) + " (", how="starts with")
        expect(row, MATCH, yn(expected[key]))
    expect("TTC b stays 0", MATCH, "yes")
    expect("PSC ε2 stays 0", MATCH, "yes")

    # Per-test values: the peaks, computed from the series.
    for name, peak in peaks.items():
        if not re.search(r"\| peak σ1/σ3 \(–\) \|.*\b%s\b" % re.escape(f"{peak:.3f}"), text):
            errors.append(f"per-test table lacks peak σ1/σ3 {peak:.3f} of {name}")

    # Every embedded figure exists, and the paper's Figures 2-12 are all there.
    links = re.findall(r"!\[[^]]*\]\(([^)]+)\)", text)
    for link in links:
        if not link.startswith("figures/") or not os.path.isfile(os.path.join(run_dir, link)):
            errors.append(f"figure link {link} does not resolve inside the run directory")
    for n in range(2, 13):
        if not any(os.path.basename(link).startswith(f"fig{n:02d}_") for link in links):
            errors.append(f"no Figure {n} embedded")
    assert not errors, "\n".join(errors)


@pytest.fixture(scope="module")
def alike(tmp_path_factory, make_fake_run):
    """A run alike to the paper: figures.py, then report.py."""
    run_dir = make_fake_run(tmp_path_factory.mktemp("alike") / "run")
    tool("figures", run_dir)
    tool("report", run_dir)
    return run_dir


@pytest.fixture(scope="module")
def diverging(tmp_path_factory, make_fake_run):
    """A run whose tests diverge: report.py alone draws the missing figures."""
    run_dir = make_fake_run(tmp_path_factory.mktemp("diverging") / "run", "--variant", "diverging")
    tool("report", run_dir)
    return run_dir


def test_alike_run_figures(alike):
    check_pngs(os.path.join(alike, "figures"))


def test_alike_run_report(alike):
    check_report(alike)


def test_package_on_alike_run(alike):
    """Series columns by header, units, a series without ratio13."""
    run = results.load_run(alike)
    for test in run.test_names:
        # Without a ratio13 column (a translated script's series) `celldem summarize` takes s11/s33.
        lammps_like = {k: v for k, v in run.test(test).items() if k not in ("ratio13", "b")}
        fd, path = tempfile.mkstemp(suffix=".csv")
        with os.fdopen(fd, "w") as f:
            f.write(",".join(lammps_like) + "\n")
            for row in zip(*lammps_like.values()):
                f.write(",".join(repr(float(v)) for v in row) + "\n")
        got = binary.summarize(path)["peak_ratio13"]
        os.remove(path)
        want = run.quantity(test, "peak_ratio13")
        assert abs(got - want) <= 1e-9 * got, f"{test}: the peak of s11/s33 ({got}) differs from ratio13's ({want})"
    assert run.quantity("psc", "end_window.ev") == run.test_summary("psc")["end_window"]["ev"], \
        "Run.quantity does not follow a key path"
    assert (run.unit("s11"), run.unit("e1")) == ("Pa", "-"), "units from series.columns.json"
    assert plotting.unit_text(run.unit("s11"), 1e-3) == "(kPa)" and plotting.unit_text(run.unit("e1"), 100) == "(%)", \
        "axis units"


def test_report_quotes_summary(alike, tmp_path):
    """The report quotes summary.json's peak, ε1 and b at the peak, not values recomputed from the series."""
    edited = str(tmp_path / "edited")
    shutil.copytree(alike, edited)
    path = os.path.join(edited, "summary.json")
    s = json.load(open(path))
    s["tests"]["psc"].update(peak_ratio13=4.321, e1_at_peak=0.0123, b_at_peak=0.377)
    s["tests"]["ttc"].update(peak_ratio13=4.4, end_window={"strain": 0.005, "ev": -0.0555, "Z": 4.56})
    with open(path, "w") as f:
        json.dump(s, f)
    tool("report", edited)
    r = read_text(os.path.join(edited, "report.md"))
    assert "| PSC b at peak σ1/σ3 | 0.396 | 0.377 | yes |" in r, "report does not quote summary.json b_at_peak"
    assert "| PSC peak σ1/σ3 exceeds TTC's | yes | no (psc 4.321, ttc 4.400) | no |" in r, \
        "report does not compare summary.json's peaks"
    assert "| peak σ1/σ3 (–) | 4.400 | 4.321 |" in r, "per-test table does not quote summary.json's peaks"
    assert "| ε1 at peak σ1/σ3 (%) | 2.500 | 1.230 |" in r, "per-test table does not quote summary.json e1_at_peak"
    assert "| εv, Z over the end window (%, –) | -5.550, 4.56 |" in r, "per-test table lacks the end window"


def test_report_shows_the_rate_check(alike, tmp_path):
    """A run with --verify-rate: the report's Rate check section quotes summary.json's verify_rate (each quantity's
    value in the test and at the rungs, its distance from I -> 0 in floors with its bounds, the fitted order and the
    verdict, the test's verdict and its reason, the floors with their source); a run without it has no such
    section."""
    edited = str(tmp_path / "verified")
    shutil.copytree(alike, edited)
    tool("report", edited)
    assert "## Rate check" not in read_text(os.path.join(edited, "report.md"))
    path = os.path.join(edited, "summary.json")
    s = json.load(open(path))
    s["tests"]["ttc"]["verify_rate"] = {
        "rungs": [0.5, 0.25], "twins": 2, "tolerance_floors": 1.0, "verdict": "unresolved", "reason": "REASON-TEST",
        "floors": {"ratio13": 0.1, "ev": 0.002, "Z": 0.05, "source": "FLOORS-SOURCE"},
        "comparisons": {"peak_ratio13": {"test": 3.9, "rungs": [3.75, 3.7], "error_floors": 3.0,
                                         "bounds95_floors": [1.25, 4.5], "order": 0.6, "order_interval90": [0.3, 1.1],
                                         "verdict": "not converged"},
                        "end_span.Z": {"test": 4.5, "rungs": [4.5, 4.5], "error_floors": 0.0,
                                       "bounds95_floors": [-0.5, 0.5], "order": 1.0,
                                       "order_interval90": [0.25, 3.0], "verdict": "converged"}}}
    with open(path, "w") as f:
        json.dump(s, f)
    tool("report", edited)
    r = read_text(os.path.join(edited, "report.md"))
    assert "## Rate check" in r and "FLOORS-SOURCE" in r and "0.500, 0.250 times its rate" in r
    assert "| ttc | peak_ratio13 | 3.900 → 3.750 → 3.700 | +3.00 [+1.25, +4.50] | 0.60 [0.30, 1.10] | not converged |" \
        in r, r[r.index("## Rate check"):][:1500]
    assert "| ttc | **the test** |  |  |  | **unresolved**: REASON-TEST |" in r, r[r.index("## Rate check"):][:1500]


def test_diverging_run_figures(diverging):
    check_pngs(os.path.join(diverging, "figures"))


def test_diverging_run_report(diverging):
    check_report(diverging)


def set_mtime(paths, when):
    stamp = time.mktime(time.strptime(when, "%Y-%m-%d"))
    for p in paths:
        os.utime(p, (stamp, stamp))


def test_stale_figures_are_redrawn(diverging, tmp_path):
    """Figures older than the run's data are redrawn; up-to-date ones are kept."""
    run_dir = str(tmp_path / "diverging")
    shutil.copytree(diverging, run_dir)
    fig = os.path.join(run_dir, "figures", "fig02_stress_ratio.png")
    data = [os.path.join(d, f) for d, _, files in os.walk(run_dir) for f in files
            if os.path.basename(d) != "figures"]
    set_mtime(glob.glob(os.path.join(run_dir, "figures", "*.png")), "2000-01-01")
    set_mtime(data, "2000-01-02")
    tool("report", run_dir)
    assert os.stat(fig).st_mtime > time.mktime(time.strptime("2001-01-01", "%Y-%m-%d")), \
        "a figure older than the run's series was not redrawn"
    set_mtime(data, "2000-01-01")
    before = os.stat(fig).st_mtime
    tool("report", run_dir)
    assert os.stat(fig).st_mtime == before, "an up-to-date figure was redrawn"


def test_partial_run(tmp_path, make_fake_run):
    """One test, optional columns and the prepared stage missing: no empty figure, no row of n/a, not a crash."""
    run_dir = make_fake_run(tmp_path / "partial", "--only", "ttc", "--no-prepared", "--no-columns-json",
                            "--reverse-columns", "--drop-columns",
                            "Hs11_Hs33,Hs11,Hw11_Hw33,DI,Zm,sin_phi,kinetic_energy,unbalanced_force")
    tool("report", run_dir)
    r = read_text(os.path.join(run_dir, "report.md"))
    for f in ("fig02_stress_ratio", "fig04_volumetric_strain", "fig06_b_value", "fig07_coordination", "test_ttc"):
        path = os.path.join(run_dir, "figures", f + ".png")
        assert os.path.isfile(path) and os.path.getsize(path) > 0, f"partial run: {f}.png missing"
    # Hw11_Hw33 comes back from Hw11/Hw33
    for f in ("fig05_dilatancy_index", "fig10_fabric_strong", "fig12_macro_micro", "extra_balance"):
        assert not os.path.exists(os.path.join(run_dir, "figures", f + ".png")), \
            f"partial run: {f}.png drawn without its columns"
        assert f + ".png" not in r, f"partial run: report links {f}.png"
    assert re.search(r"^Not judged .*PSC b at peak σ1/σ3", r, re.M), "partial run: PSC findings not listed as not judged"
    assert "| PSC b at peak σ1/σ3 |" not in r, "partial run: a row of n/a for PSC b"
    assert "| max Hs11/Hs33 (–) |" not in r, "partial run: a per-test row of n/a"
    assert "first row of ttc/series.csv" in r, "partial run: no fallback for prepared"


def test_figures_out_writes_elsewhere(alike, tmp_path):
    tool("figures", alike, "--out", tmp_path / "elsewhere")
    check_pngs(str(tmp_path / "elsewhere"))


def test_renamed_tests_are_not_the_paper(tmp_path, make_fake_run):
    """The paper's scene with tests under other names is not the paper's deck: per-test figures, no paper table."""
    run_dir = make_fake_run(tmp_path / "renamed")
    os.rename(os.path.join(run_dir, "ttc"), os.path.join(run_dir, "Squash_1"))
    os.rename(os.path.join(run_dir, "psc"), os.path.join(run_dir, "plane-2"))
    path = os.path.join(run_dir, "summary.json")
    s = json.load(open(path))
    s["tests"] = {"Squash_1": s["tests"]["ttc"], "plane-2": s["tests"]["psc"]}
    with open(path, "w") as f:
        json.dump(s, f)
    tool("report", run_dir)
    r = read_text(os.path.join(run_dir, "report.md"))
    assert "Comparison with the paper" not in r, "renamed tests: paper table"
    for t in ("Squash_1", "plane-2"):
        png = os.path.join(run_dir, "figures", f"test_{t}.png")
        assert os.path.isfile(png) and os.path.getsize(png) > 0, f"renamed tests: no figure of test {t}"
        assert f"](figures/test_{t}.png)" in r, f"renamed tests: test {t}'s figure not in the report"
    assert re.search(r"^## Per-test values", r, re.M), "renamed tests: no per-test values"
    tool("report", run_dir, "--paper")
    assert re.search(r"^## Comparison with the paper", read_text(os.path.join(run_dir, "report.md")), re.M), \
        "--paper: no paper table"


@pytest.mark.parametrize("name", ["figures", "report"])
def test_missing_run_or_summary_is_an_error(name, tmp_path):
    """A missing run directory or summary.json is an error with a message."""
    r = tool(name, tmp_path / "no-such-run", check=False)
    assert r.returncode != 0, f"{name}.py accepted a missing run dir"
    assert "run directory not found" in r.stderr, f"{name}.py: unclear message for a missing run dir"
    os.makedirs(tmp_path / "no-summary" / "ttc")
    r = tool(name, tmp_path / "no-summary", check=False)
    assert r.returncode != 0, f"{name}.py accepted a run without summary"
    assert "summary.json not found" in r.stderr, f"{name}.py: unclear message for a missing summary.json"
    assert not os.path.exists(tmp_path / "no-summary" / "report.md"), "report.md written for a run without summary.json"
