"""The report's Probes section and the probes' figures (tools/celldem/probes.py, reports/probe_figures.py) on
synthetic run folders written here, in celldem's layout (summary.json tests.<test>.probes, <test>/probes/probes.csv,
stiffness.json; docs/outputs.md).

The stress probes' responses follow a model whose envelope is known in closed form: an isotropic elastic compliance
E (de = E ds) plus a plastic compliance P along σ1's axis for the directions that load it (de_p = P max(0, ds11) e1):
the largest total response is along a = 0, E + P per unit stress, the smallest E, the most plastic a = 0, and the
sums over the directions follow from cos 45° alone. A point not run, a probe that failed, listed directions, the π
plane and strain probes with the contact network's stiffness are in the folder too."""

import json
import math
import os

import numpy as np
import pytest

from celldem import probes, results
from celldem.reports import probe_figures
from checking import is_png, read_text, tool

ELASTIC = 2.0e-8   # [1/Pa] E
PLASTIC = 6.0e-8   # [1/Pa] P
S3 = 1e5
HEADER = ("point,point_step,point_e1,kind,probe,magnitude,angle_deg,d11,d22,d33,d12,d13,d23,"
          "ds11,ds22,ds33,ds12,ds13,ds23,de1,de2,de3,dg12,dg13,dg23,"
          "de1_plastic,de2_plastic,de3_plastic,dg12_plastic,dg13_plastic,dg23_plastic,"
          "de1_elastic,de2_elastic,de3_elastic,dg12_elastic,dg13_elastic,dg23_elastic,"
          "ds11_residual,ds22_residual,ds33_residual,ds12_residual,ds13_residual,ds23_residual,controlled,status")
FAILURE = "failed: step 1200: the servo of x2 lost its target"
NOT_RUN = "the test ended before e1 reached 0.05"


def rendulic(a):
    """celldem's Rendulic direction at angle a (solver/run/probes.cpp)."""
    return np.array([math.cos(a), math.sin(a) / math.sqrt(2), math.sin(a) / math.sqrt(2)])


def pi_plane(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([2 * c / math.sqrt(6), -c / math.sqrt(6) + s / math.sqrt(2), -c / math.sqrt(6) - s / math.sqrt(2)])


def cells(values):
    return [repr(float(v)) for v in values]


def stress_row(point, step, e1, name, magnitude, angle_deg, d, fail=None):
    """One probes.csv row of the model response (or a failed probe: its cells empty)."""
    head = [point, str(step), repr(e1), "stress", name, repr(magnitude), repr(angle_deg)] + cells(list(d) + [0, 0, 0])
    if fail:
        return ",".join(head + [""] * 30 + ["false", fail])
    ds = magnitude * np.asarray(d)
    plastic = np.array([PLASTIC * max(0.0, ds[0]), 0.0, 0.0])
    total = ELASTIC * ds + plastic
    zeros = [0.0] * 3
    values = list(ds) + zeros + list(total) + zeros + list(plastic) + zeros + list(total - plastic) + zeros + [0.0] * 6
    return ",".join(head + cells(values) + ["true", "ok"])


def write(path, text):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)


def write_series(run_dir, test):
    e1 = np.linspace(0, 0.01, 11)
    ratio = 1 + 2 * e1 / 0.01
    lines = ["step,e1,s11,s22,s33,ratio13,ev"] + [
        f"{k * 1000},{x!r},{r * S3!r},{S3!r},{S3!r},{r!r},{-0.1 * x!r}" for k, (x, r) in enumerate(zip(e1, ratio))]
    write(os.path.join(run_dir, test, "series.csv"), "\n".join(lines) + "\n")


def point_entry(test, point, e1, step, count, failed=0, **more):
    return dict(status="ran with failures" if failed else "ran", probes=count, controlled=count - failed,
                failed=failed, e1=e1, step=float(step), folder=f"{test}/probes/{point}", **more)


def stress_set(run_dir, test, plane, directions, magnitudes, points, fail=None):
    """A stress-probe set: probes.csv of the model at `points` [(name, e1, step)] and summary.json's entry."""
    rows, entries = [HEADER], {}
    for point, e1, step in points:
        failed = 0
        for m_index, m in enumerate(magnitudes):
            prefix = f"m{m_index + 1}-" if len(magnitudes) > 1 else ""
            for k, d in enumerate(directions):
                name = f"{prefix}d{k:02d}"
                angle = 360.0 * k / len(directions) if plane != "list" else 0.0
                broken = fail if fail and fail[0] == point and fail[1] == name else None
                failed += bool(broken)
                rows.append(stress_row(point, step, e1, name, m, angle, d, broken and FAILURE))
        more = {"linearity": {"median_ratio": 0.987, "meaning": "..."}} if len(magnitudes) > 1 and not failed else {}
        entries[point] = point_entry(test, point, e1, step, len(magnitudes) * len(directions), failed, **more)
    write(os.path.join(run_dir, test, "probes", "probes.csv"), "\n".join(rows) + "\n")
    info = {"kind": "stress", "plane": plane, "magnitudes": magnitudes, "steps": 3000, "hold_steps": 1000,
            "table": f"{test}/probes/probes.csv", "points": entries}
    return info


ASYMMETRIC = np.diag([200e6, 180e6, 130e6, 75e6, 70e6, 60e6])
ASYMMETRIC[0, 1] = 30e6  # |C - C^T| / |C| known by hand
NETWORK_RELAXED_DIAGONAL = [190e6, 170e6, 120e6, 71e6, 66e6, 55e6]
NETWORK_RELAXED_ASYMMETRY = 0.0321  # celldem's, as stiffness.json holds it: the report prints it, never recomputes it


def strain_set(run_dir, test):
    """Strain probes at one point: stiffness.json with per-magnitude matrices and the contact network's."""
    rows = [HEADER]
    for k, name in enumerate(("e11", "e22", "e33", "g12", "g13", "g23")):
        unit = [0.0] * 6
        unit[k] = 1.0
        ds = ASYMMETRIC[:, k] * 1e-5
        strain = [1e-5 * u for u in unit]
        values = list(ds) + strain + [0.0] * 6 + strain + [0.0] * 6
        rows.append(",".join(["e1_0.002", "2000", "0.002", "strain", name, "1e-05", "0"] + cells(unit)
                             + cells(values) + ["true", "ok"]))
    write(os.path.join(run_dir, test, "probes", "probes.csv"), "\n".join(rows) + "\n")
    elastic = ASYMMETRIC.tolist()
    tangent = (0.95 * ASYMMETRIC).tolist()
    stiffness = {"voigt_order": list(probes.VOIGT), "units": "Pa per unit strain",
                 "points": {"e1_0.002": {"step": 2000, "e1": 0.002, "magnitudes": [
                     {"magnitude": 1e-5, "elastic": elastic, "tangent": tangent, "elastic_asymmetry": 0.1111,
                      "tangent_asymmetry": 0.2222}],
                     "network": {"affine": np.diag([250e6] * 3 + [90e6] * 3).tolist(),
                                 "relaxed": np.diag(NETWORK_RELAXED_DIAGONAL).tolist(),
                                 "affine_asymmetry": 0.0, "relaxed_asymmetry": NETWORK_RELAXED_ASYMMETRY}}}}
    write(os.path.join(run_dir, test, "probes", "stiffness.json"), json.dumps(stiffness))
    return {"kind": "strain", "magnitudes": [1e-5], "steps": 2000, "hold_steps": 1000,
            "table": f"{test}/probes/probes.csv", "stiffness": f"{test}/probes/stiffness.json",
            "points": {"e1_0.002": point_entry(test, "e1_0.002", 0.002, 2000, 6, elastic_asymmetry=0.1111)}}


@pytest.fixture(scope="module")
def probe_run(tmp_path_factory):
    """A run whose ttc (Rendulic, 8 directions, 2 magnitudes, a point not run, a failed probe), psc (π plane, 6
    directions), listed (3 listed directions) and shear (strain probes) tests ran probes; report.py on it."""
    run_dir = str(tmp_path_factory.mktemp("probes") / "run")
    rendulic_directions = [rendulic(2 * math.pi * k / 8) for k in range(8)]
    listed = [np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.ones(3) / math.sqrt(3)]
    points = [("e1_0.002", 0.002, 2000), ("peak", 0.0075, 7500)]
    ttc = stress_set(run_dir, "ttc", "rendulic", rendulic_directions, [2000.0, 4000.0], points,
                     fail=("peak", "m2-d05"))
    ttc["points"]["e1_0.05"] = {"status": "not run", "reason": NOT_RUN, "e1": 0.05, "step": 0}
    tests = {"ttc": ttc,
             "psc": stress_set(run_dir, "psc", "pi", [pi_plane(2 * math.pi * k / 6) for k in range(6)], [3000.0],
                               points),
             "listed": stress_set(run_dir, "listed", "list", listed, [2000.0], points[:1]),
             "shear": strain_set(run_dir, "shear")}
    for test in tests:
        write_series(run_dir, test)
    summary = {"deck": "probes.json", "tests": {t: {"probes": info, "controlled": True} for t, info in tests.items()}}
    write(os.path.join(run_dir, "summary.json"), json.dumps(summary))
    tool("report", run_dir)
    return run_dir


def section(text, title):
    start = text.index(f"## {title}\n")
    end = text.find("\n## ", start + 1)
    return text[start:] if end < 0 else text[start:end]


def test_envelope_lies_along_its_directions():
    """An isotropic response (de = E ds) puts each tip at its direction's own angle, E from the origin: the plane
    coordinates use the basis celldem builds the directions on, in the Rendulic and the π plane."""
    for plane, direction in (("rendulic", rendulic), ("pi", pi_plane)):
        rows = []
        for k in range(12):
            a = 2 * math.pi * k / 12
            line = stress_row("p", 1, 0.0, f"d{k:02d}", 1000.0, math.degrees(a), direction(a))
            rows.append(probes.parse_row(HEADER.split(","), line.split(",")))
        tips = probes.envelope(rows, plane, "elastic")
        for k, (across_u1, along_u2) in enumerate(tips):
            a = 2 * math.pi * k / 12
            assert math.isclose(across_u1, ELASTIC * math.cos(a), abs_tol=1e-20)
            assert math.isclose(along_u2, ELASTIC * math.sin(a), abs_tol=1e-20)
            assert math.isclose(probes.direction_angle(rows[k], plane), math.degrees(a) % 360, abs_tol=1e-9)


def test_envelope_findings_match_the_model(probe_run):
    """The findings of the Rendulic envelope against the model's closed form."""
    run = results.load_run(probe_run)
    ttc = probes.load(run, "ttc")
    f = probes.envelope_findings(ttc.point_rows("e1_0.002", 2000.0), "rendulic")
    assert f["largest"].startswith("d00 (0°") and f["most_plastic"].startswith("d00 (0°")
    assert math.isclose(f["ratio"], (ELASTIC + PLASTIC) / ELASTIC, rel_tol=1e-9)
    assert math.isclose(f["most_plastic_compliance"], PLASTIC, rel_tol=1e-9)
    assert math.isclose(f["most_plastic_over_total"], PLASTIC / (ELASTIC + PLASTIC), rel_tol=1e-9)
    c = math.cos(math.pi / 4)
    # 8 directions: a = 0 loads σ1 fully, a = ±45° by cos 45°, the other five not at all
    total = (ELASTIC + PLASTIC) + 2 * math.hypot((ELASTIC + PLASTIC) * c, ELASTIC * c) + 5 * ELASTIC
    assert math.isclose(f["plastic_over_total"], PLASTIC * (1 + 2 * c) / total, rel_tol=1e-9)


def test_asymmetry_is_celldems(tmp_path):
    """Each matrix's asymmetry is the one stiffness.json holds (none for a network of an older run)."""
    entry = {"magnitudes": [{"magnitude": 1e-5, "elastic": ASYMMETRIC.tolist(), "elastic_asymmetry": 0.1111}],
             "network": {"affine": np.eye(6).tolist(), "relaxed": np.eye(6).tolist(), "relaxed_asymmetry": 0.5}}
    got = {label: asym for label, _, asym in probes.stiffness_matrices(entry)}
    assert got == {"elastic": 0.1111, "network affine": None, "network relaxed": 0.5}


def test_plane_bases_are_the_solvers(celldem):
    """The probe planes' bases are `celldem schema --constants`'s, on which the solver builds the directions."""
    bases = probes.plane_bases(celldem)
    assert sorted(bases) == ["pi", "rendulic"]
    assert probes.in_a_plane("pi") and not probes.in_a_plane("list")
    x, y = probes.in_plane("rendulic", np.array([1.0, 0.5, 0.5]))[0]
    assert math.isclose(x, 1.0) and math.isclose(y, math.sqrt(0.5))


def test_probes_section(probe_run):
    """Per test and point: status, counts, linearity or asymmetry, the reason of a point not run, the failed probe,
    the measured sentences, the stiffness table with the network's, and the figures linked."""
    text = read_text(os.path.join(probe_run, "report.md"))
    assert "## Probes" in text
    probes_text = section(text, "Probes")
    for test in ("ttc", "psc", "listed", "shear"):
        assert f"### {test}\n" in probes_text, f"no subsection for {test}"
    assert "stress probes in the rendulic plane, 8 directions, M = 2, 4 kPa" in probes_text
    assert "stress probes in the pi plane, 6 directions, M = 3 kPa" in probes_text
    assert "stress probes along listed directions, 3 directions" in probes_text
    assert "| e1_0.002 | 0.200 | 2000 | ran | 16 / 16 / 0 | 0.987 | — |  |" in probes_text
    assert "| peak | 0.750 | 7500 | **ran with failures** | 16 / 15 / 1 | n/a | — |  |" in probes_text
    assert f"| e1_0.05 | — | — | **not run** | — | n/a | — | {NOT_RUN} |" in probes_text
    assert f"- peak, m2-d05: {FAILURE}" in probes_text
    ratio = (ELASTIC + PLASTIC) / ELASTIC
    assert (f"- e1_0.002, M = 2 kPa: the largest total response is along d00 (0°; Δσ/M = 1, 0, 0), {ratio:.3g} times "
            "the smallest") in probes_text
    assert f"d00 (0°; Δσ/M = 1, 0, 0), {PLASTIC * 1e6:.3g} per MPa" in probes_text
    # strain probes: the elastic asymmetry from summary.json, the diagonals in MPa, the network's rows
    assert "| e1_0.002 | 0.200 | 2000 | ran | 6 / 6 / 0 | 0.111 | — |  |" in probes_text
    assert "| elastic | 200 | 180 | 130 | 75 | 70 | 60 | 0.111 |" in probes_text
    assert "| tangent | 190 | 171 | 123.5 | 71.25 | 66.5 | 57 | 0.222 |" in probes_text
    relaxed = " | ".join(f"{v * 1e-6:.4g}" for v in NETWORK_RELAXED_DIAGONAL)
    assert f"| network relaxed | {relaxed} | {NETWORK_RELAXED_ASYMMETRY:.3f} |" in probes_text
    assert "| network affine |" in probes_text
    for stem in ("probe_envelopes", "probe_stiffness_shear"):
        assert f"](figures/{stem}.png)" in probes_text, f"{stem} not linked in the Probes section"
        assert is_png(os.path.join(probe_run, "figures", f"{stem}.png")), f"{stem}.png not written"
    assert "probe_stiffness_ttc" not in text, "a stiffness figure for stress probes"
    order = [text.index(h) for h in ("## Controls", "## Probes", "## Per-test values")]
    assert order == sorted(order), "the Probes section is not between Controls and the per-test values"


def test_envelope_rows_share_points():
    """The envelopes' figure: one row per point that a test has probes of, in order of first appearance, so tests'
    envelopes at the same point share a row."""
    def fake(points, ran):
        return probes.ProbeSet("t", {"points": {p: {} for p in points}}, [{"point": p} for p in ran], None)
    sets = [fake(["e1_0.002", "peak", "e1_0.05"], ["e1_0.002"]), fake(["e1_0.002", "end", "peak"], ["peak", "end"])]
    assert probe_figures.point_rows(sets) == ["e1_0.002", "peak", "end"]


def test_no_probes_no_section(tmp_path):
    """A run without probes has no Probes section and no probe figure."""
    run_dir = str(tmp_path / "plain")
    write_series(run_dir, "ttc")
    write(os.path.join(run_dir, "summary.json"), json.dumps({"tests": {"ttc": {"controlled": True}}}))
    tool("report", run_dir)
    text = read_text(os.path.join(run_dir, "report.md"))
    assert "## Probes" not in text and "probe_" not in text
    assert not [f for f in os.listdir(os.path.join(run_dir, "figures")) if f.startswith("probe_")]
