"""The analysis half of tools/study.py (tools/celldem/study/analysis.py) without running a simulation: the compared
quantities (summary.json's, and `celldem summarize` against values worked out by hand), what plan.json gives, the
noise floor, the errors, the Pareto front, the presets' choice, the stability and servo measures, on known inputs
and on a synthetic study root (make_fake_study.py); then that `study.py analyse` writes study.json, study.md and the
charts, and that report.py links the study."""

import json
import math
import os
import tempfile

import numpy as np
import pytest

from celldem import binary, decks
from celldem.study import analysis as sa, runs as study, scene
from checking import check, read_text, tool


def test_pareto_front():
    # Lower cost and lower error win; a tie in one and a loss in the other is dominated.
    pts = [(10, 1.0), (5, 2.0), (20, 0.5), (12, 1.5), (5, 3.0), (1, 10.0), (20, 0.6), (None, 1.0)]
    check("pareto", sa.pareto_front(pts), [5, 1, 0, 2])
    check("pareto of one", sa.pareto_front([(3, 4)]), [0])
    check("pareto keeps equal points", sa.pareto_front([(2, 1.0), (2, 1.0), (3, 1.0)]), [0, 1])


def test_noise_floor():
    # Sample standard deviation (ddof 1) over the seeds; one seed gives no floor.
    ref = [{"ttc": {"peak_ratio": v}} for v in (2.9, 3.0, 3.1, 3.0)]
    mean, floor = sa.noise_floor(ref, (("ttc", "peak_ratio"),))
    check("floor mean", mean[("ttc", "peak_ratio")], 3.0)
    check("floor std", floor[("ttc", "peak_ratio")], math.sqrt(0.02 / 3))
    check("floor of one", sa.noise_floor(ref[:1], (("ttc", "peak_ratio"),))[1][("ttc", "peak_ratio")], None)


def test_errors_and_score():
    # Signed difference, normalised by the floor; the mean over seeds; the score is the largest.
    q1, q2 = ("ttc", "peak_ratio"), ("psc", "b_peak")
    fl = {q1: 0.1, q2: 0.02}
    e = sa.errors_against({"ttc": {"peak_ratio": 3.05}, "psc": {"b_peak": 0.37}},
                          {"ttc": {"peak_ratio": 3.0}, "psc": {"b_peak": 0.40}}, fl, (q1, q2))
    check("error value", e[q1][0], 0.05, 1e-9)
    check("error normalised", e[q1][1], 0.5, 1e-9)
    check("error sign", e[q2][0], -0.03, 1e-9)
    check("score", sa.score_of(e), 1.5, 1e-9)
    c = sa.combine_seeds([{q1: (0.03, None)}, {q1: (-0.05, None)}], fl, (q1,))
    check("mean over seeds", c[q1][0], -0.01, 1e-12)
    check("mean normalised", c[q1][1], 0.1, 1e-12)
    check("missing quantity skipped", sa.errors_against({"ttc": {}}, {"ttc": {"peak_ratio": 1}}, fl, (q1,)), {})


def test_presets_cheapest_within():
    rows = [{"key": "a", "cost": 10, "score": 0.9}, {"key": "b", "cost": 5, "score": 1.2},
            {"key": "c", "cost": 20, "score": 0.3}, {"key": "d", "cost": 1, "score": None}]
    check("fast", sa.cheapest_within(rows, 1.0)["key"], "a")
    check("balanced", sa.cheapest_within(rows, 0.5)["key"], "c")
    check("none within", sa.cheapest_within(rows, 0.1), None)


def test_preset_preparation_must_meet_the_rule():
    # A preset with another dt or servo cap needs a sample prepared with those that meets the rule too.
    rule = {"stress": 1.0, "volume": 2.0}
    cap = 1.0e-6   # the paper's servo.max_strain_increment (the reference runs' summary.json setting)
    prep = [{"group": "prepare_dt", "sample_time_step": 3e-6, "sample_servo_cap": cap, "score_stress": 0.5,
             "score_volume": 2.5},
            {"group": "prepare_dt", "sample_time_step": scene.PAPER_DT, "sample_servo_cap": 5e-6, "score_stress": 0.5,
             "score_volume": 0.5}]
    check("meets", sa.meets({"score_stress": 1.0, "score_volume": 2.0}, rule), True)
    check("fails on volume", sa.meets({"score_stress": 0.1, "score_volume": 2.1}, rule), False)
    check("preparation as the paper's", sa.preparation_ok(prep, scene.PAPER_DT, cap, rule, cap), True)
    check("preparation failing the rule", sa.preparation_ok(prep, 3e-6, cap, rule, cap), False)
    check("preparation meeting a looser rule",
          sa.preparation_ok(prep, 3e-6, cap, {"stress": 1.0, "volume": 5.0}, cap), True)
    check("preparation never checked", sa.preparation_ok(prep, 5e-6, cap, {"stress": 1.0, "volume": 5.0}, cap), False)
    check("preparation with a larger cap", sa.preparation_ok(prep, scene.PAPER_DT, 5e-6, rule, cap), True)
    check("cap never checked", sa.preparation_ok(prep, scene.PAPER_DT, 2.5e-6, rule, cap), False)
    check("paper's cap unknown", sa.preparation_ok([], scene.PAPER_DT, cap, rule, None), False)


def test_preset_deck_reuses_the_papers_sample():
    # A preset whose preparation was not checked starts from the paper's prepared sample.
    paper = decks.load()
    own = study.preset_deck(paper, "x", 3e-6, 1.5e-6, 133, "d")
    reuse = study.preset_deck(paper, "x", 3e-6, 1.5e-6, 133, "d", preparation="paper")
    check("own preparation kept", ("prepare" in own, "initial_state" in own), (True, False))
    check("paper's sample reused", (reuse.get("prepare"), reuse.get("initial_state")),
          (None, study.PAPER_PREPARED_STATE))
    check("servo cap 5 × Δε1", reuse["servo"]["max_strain_increment"], 7.5e-6, 1e-12)
    check("strain increment and rows", (reuse["tests"][1]["axes"]["x1"], reuse["tests"][1]["output_interval"]),
          ({"strain_increment": 1.5e-6}, 133))
    check("paper deck untouched", "initial_state" in paper or paper["time_step"] != 1e-6, False)


def test_compared_quantities_are_summary_json_s():
    # Peak, ε1 and b at the peak, the end window's εv and Z, the latter only when the run reached the end strain
    # (up to the rounding of its steps).
    info = {"peak_ratio13": 3.0, "e1_at_peak": 0.01, "b_at_peak": 0.4, "final_e1": 0.03 - 1e-12,
            "end_window": {"strain": 0.005, "ev": -0.02, "Z": 4.4}, "e1_at_peak_centre": 0.015}
    m = sa.test_metrics(info, 0.03)
    check("peak", m["peak_ratio"], 3.0)
    check("e1 at peak: the row of the max", m["e1_peak"], 0.01)
    check("b at peak", m["b_peak"], 0.4)
    check("ev at end", m["ev_end"], -0.02)
    check("Z at end", m["Z_end"], 4.4)
    check("short run: no end values", sa.test_metrics(info, 0.04)["Z_end"], None)
    check("null in summary.json", sa.test_metrics(dict(info, b_at_peak=None), 0.03)["b_peak"], None)


def summarize(columns, end_axis="x1"):
    fd, path = tempfile.mkstemp(suffix=".csv")
    with os.fdopen(fd, "w") as f:
        f.write(",".join(columns) + "\n")
        for row in zip(*columns.values()):
            f.write(",".join(repr(float(v)) for v in row) + "\n")
    try:
        return binary.summarize(path, end_axis)
    finally:
        os.remove(path)


def test_celldem_summarize_against_hand_worked_series(celldem):
    # summary.json's definitions (solver/run/summary.cpp) through `celldem summarize`, on series whose answers are
    # worked out by hand (series of LAMMPS/LIGGGHTS have no summary.json: the cross-check summarizes them so).
    e1 = np.array([0.0, 0.01, 0.02, 0.03 - 1e-12])
    s = {"e1": e1, "ratio13": np.array([1.0, 3.0, 2.5, 2.4]), "b": np.array([np.nan, 0.4, 0.3, 0.2]),
         "ev": np.array([0.0, 0.001, -0.01, -0.02]), "Z": np.array([6.0, 5.0, 4.5, 4.4])}
    m = summarize(s)
    check("summarize peak", m["peak_ratio13"], 3.0)
    check("summarize e1 at peak", m["e1_at_peak"], 0.01)
    check("summarize b at peak", m["b_at_peak"], 0.4)
    check("summarize plateau of one row", m["e1_peak_range"], [0.01, 0.01])
    check("summarize final", (m["final_e1"], m["ev_final"], m["Z_final"], m["b_final"]),
          (0.03 - 1e-12, -0.02, 4.4, 0.2))
    check("summarize end window of one row", (m["end_window"]["ev"], m["end_window"]["Z"]), (-0.02, 4.4))
    s2 = {"e1": np.linspace(0.0, 0.03, 31), "ev": np.linspace(0.0, -0.03, 31), "Z": np.linspace(6.0, 3.0, 31),
          "s11": np.linspace(1.0, 3.0, 31) * 1e5, "s33": np.full(31, 1e5)}
    m = summarize(s2)
    check("summarize s11/s33 without ratio13", m["peak_ratio13"], 3.0)
    check("summarize ev mean over the last 0.5 %", m["end_window"]["ev"], -0.0275, 1e-9)
    check("summarize Z mean over the last 0.5 %", m["end_window"]["Z"], 3.25, 1e-9)
    check("summarize without b", m["b_at_peak"], None)
    check("summarize no peak: the largest s11/s33 is the last row", m["peak_reached"], False)
    s3 = {"e1": np.array([0.0, 0.01, 0.02, 0.03, 0.04]), "ratio13": np.array([1.0, 2.98, 3.0, 2.99, 2.5]),
          "ev": np.zeros(5), "Z": np.zeros(5), "e2": np.array([0.0, 0.0, 0.0, 0.006, 0.009])}
    m = summarize(s3)
    check("summarize plateau: rows within 1 % of the peak", m["e1_peak_range"], [0.01, 0.03])
    check("summarize plateau centre", m["e1_at_peak_centre"], 0.02)
    check("summarize end window on x2", summarize(s3, "x2")["end_window"]["ev"], 0.0)
    check("summarize end window on x2: rows", summarize(dict(s3, ev=np.arange(5.0)), "x2")["end_window"]["ev"], 3.5)


def test_what_a_deck_implies_comes_from_plan_json():
    plan = {"time_step_ratio": 0.5, "critical_time_step": 6e-6, "sample": {"count": 10, "density": 2000.0,
            "mean_diameter": 1e-3}, "particle_types": [{"mass": 1.0}, {"mass": 3.0}],
            "tests": [{"name": "ttc", "steps": 100, "strain_rate": 0.2, "inertial_number": 1e-4,
                       "axes": {"x1": {"strain_increment": 2e-7}, "x2": {"stress": 5e4}, "x3": {"stress": 7e4}}}]}
    entry = {"plan": plan}
    check("planned steps", sa.planned(entry, "steps"), 100.0)
    check("planned ratio", sa.describe(entry)["dt_over_tc"], 0.5)
    check("planned inertial number", sa.describe(entry)["inertial_number"], 1e-4)
    check("planned mean diameter", sa.planned(entry, "mean_diameter"), 1e-3)
    check("no plan", sa.describe({"plan": None})["steps_per_test"], None)
    check("solid volume", binary.solid_volume(plan), 10 * 2.0 / 2000.0)
    check("stress targets", sa.stress_targets(entry, "ttc"), {"s22": 5e4, "s33": 7e4})
    check("kinetic energy / (p V)",
          sa.kinetic_ratio({"kinetic_energy": np.array([1.0]), "void_ratio": np.array([1.0])}, 0.5)[0],
          1.0 / (scene.P_REF * 0.5 * 2.0))


def test_time_step_warning_bound_comes_from_the_plan(celldem):
    """The settings the loading-rate threshold uses are those whose time step celldem does not warn about: the
    bound of `celldem plan --json`'s time_step_bounds, not a number of the tools'."""
    plan = binary.plan(os.path.join(binary.REPO, "tests", "run", "small_run.json"), celldem)
    warn = [b for b in plan["time_step_bounds"] if b["action"] == "warn" and b["when"] == "above"]
    assert len(warn) == 1, f"celldem plan lists {len(warn)} bounds warned above"
    bound = warn[0]["time_step"]
    assert 0 < bound < plan["critical_time_step"]
    check("below the bound", sa.within_time_step_warning(dict(plan, time_step=0.99 * bound)), True)
    check("at the bound", sa.within_time_step_warning(dict(plan, time_step=bound)), True)
    check("above the bound", sa.within_time_step_warning(dict(plan, time_step=1.01 * bound)), False)
    check("a plan without the table", sa.within_time_step_warning({"time_step": 1e-6}), None)
    check("no plan", sa.describe({"plan": None})["dt_within_warning"], None)
    check("describe", sa.describe({"plan": dict(plan, time_step=1.01 * bound)})["dt_within_warning"], False)

    # Only settings within the warning count for the loading-rate thresholds.
    def row(i, score, within):
        return {"group": "strain_increment", "inertial_number": i, "score_stress": score, "score_volume": score,
                "ke_max": 1e-6, "dt_within_warning": within, "dt_over_tc": None}
    limits = sa.thresholds([row(1e-4, 0.5, True), row(3e-3, 0.5, False), row(2e-3, 2.0, True),
                            row(1e-5, 5.0, None)], [], {"dt": [], "servo": []})
    check("largest I inside the floor, within the warning", limits["I_stress_ok_max"], 1e-4)
    check("smallest I outside the floor, within the warning", limits["I_stress_bad_min"], 2e-3)


def test_servo_error():
    # std, |mean| and max of σ/target − 1 after the first 10 % of rows.
    n = 100
    s22 = 1e5 * (1 + np.where(np.arange(n) % 2 == 0, 0.02, 0.0))
    s33 = np.full(n, 1e5)
    std, bias, mx = sa.servo_error_stats({"s22": s22, "s33": s33}, {"s22": 1e5, "s33": 1e5})
    all_err = np.concatenate([s22[10:] / 1e5 - 1, s33[10:] / 1e5 - 1])
    check("servo std", std, float(np.std(all_err)), 1e-12)
    check("servo bias", bias, float(abs(np.mean(all_err))), 1e-12)
    check("servo max", mx, 0.02, 1e-12)
    s22[50] = np.nan
    check("servo non-finite", sa.servo_error_stats({"s22": s22}, {"s22": 1e5})[0], math.inf)


@pytest.fixture(scope="module")
def analysed_study(tmp_path_factory, make_fake_study):
    """study.py analyse on a synthetic study root."""
    root = make_fake_study(tmp_path_factory.mktemp("study") / "study")
    tool("study", "analyse", "--root", root)
    return root


def test_analyse_writes_its_files(analysed_study):
    for f in ("study.json", "study.md", "figures/pareto.png", "figures/stability.png", "figures/reference.png"):
        path = os.path.join(analysed_study, f)
        assert os.path.isfile(path) and os.path.getsize(path) > 0, f"analyse did not write {f}"


def test_study_json_against_the_synthetic_answers(analysed_study):
    root = analysed_study
    got = json.load(open(f"{root}/study.json"))
    want = json.load(open(f"{root}/expected.json"))

    def close(what, got, want):
        check(what, got, want, 1e-9)
    close("floor ttc peak", got["noise_floor"]["ttc.peak_ratio"][1], want["floor_ttc_peak"])
    close("floor psc b", got["noise_floor"]["psc.b_peak"][1], want["floor_psc_b"])
    close("floor ttc ev", got["noise_floor"]["ttc.ev_end"][1], want["floor_ttc_ev_end"])
    rows = {r["key"]: r for r in got["rows"]}
    for key, score in want["scores"].items():
        close(f"score of {key}", rows[key]["score"], score)
    close("reference score", rows["reference"]["score"], 0.0)
    front = sorted(k for k, r in rows.items() if r["pareto"])
    assert front == want["pareto"], "Pareto front"
    for name in ("fast", "balanced"):
        p = got["presets"].get(name)
        assert p is not None and p["row"] == want[name], f"preset {name}: got {p and p['row']}, want {want[name]}"
        assert p["preparation"] == "own", \
            f"preset {name}: its preparation was checked, so it should keep its own, got {p['preparation']}"
    if got["presets"].get("balanced"):
        close("balanced speed-up in steps", got["presets"]["balanced"]["test_steps_speedup"], 5.0)
        close("balanced measured speed-up", got["presets"]["balanced"]["measured_speedup"], 100.0 / 20.0)
    servo = got["stability"]["servo"][0]
    close("servo std", servo["std"], want["servo_std"])
    assert not servo["holds"], "a servo 0.7 % off its target must not 'hold'"
    states = {r["name"]: r["state"] for r in got["stability"]["dt"]}
    for name, state in want["stability"].items():
        assert states.get(name) == state, f"stability of {name}: got {states.get(name)}, want {state}"
    md = read_text(f"{root}/study.md")
    for needle in ("## Noise floor", "## Presets", "## Stability map", "![error against run time](figures/pareto.png)"):
        assert needle in md, f"study.md lacks {needle!r}"


def test_write_rules_from_the_synthetic_study(analysed_study, tmp_path):
    """analyse --write-rules: one level per setting of the front of test steps against error, each the cheapest
    setting within its tolerance, the lowest at RULES_MIN_TOLERANCE, time steps as fractions of the plan's limit."""
    path = tmp_path / "rules.json"
    tool("study", "analyse", "--root", analysed_study, "--write-rules", path)
    table = json.load(open(path))
    got = json.load(open(f"{analysed_study}/study.json"))
    rows = [r for r in got["rows"] if r["key"] in {lv["evidence"]["run"].split(":")[0] for lv in table["levels"]}]
    levels = table["levels"]
    assert len(levels) >= 2, levels
    tolerances = [lv["tolerance"] for lv in levels]
    assert tolerances == sorted(set(tolerances)), "levels must ascend"
    assert tolerances[0] == sa.RULES_MIN_TOLERANCE  # the cheapest setting as good as the reference's round-off
    limit = got["scene"]["critical_time_step"]
    by_key = {r["key"]: r for r in got["rows"]}
    ref = by_key["reference"]
    candidates = [r for r in got["rows"] if r["group"] in ("reference", "strain_increment", "time_step", "combined")
                  and r["count"] == scene.SCENE_COUNT and len(r["seeds"]) >= 2 and r["score"] is not None
                  and math.isfinite(r["score"]) and r["dt_within_warning"] is not False]
    for lv in levels:
        row = by_key[lv["evidence"]["run"].split(":")[0]]
        assert row["score"] <= lv["tolerance"] + 1e-9 and lv["tolerance"] <= sa.RULES_MAX_TOLERANCE
        check("time step fraction", lv["time_step_fraction"], row["time_step"] / limit, 1e-3)
        check("inertial number", lv["inertial_number"], row["inertial_number"], 1e-3)
        check("speed-up", lv["evidence"]["speedup"], ref["steps_per_test"] / row["steps_per_test"], 1e-3)
        # No setting within the tolerance takes fewer test steps.
        assert all(r["steps_per_test"] >= row["steps_per_test"] for r in candidates if r["score"] <= lv["tolerance"])
    assert rows, "the levels name the study's settings"


def test_missing_study_root_is_an_error(tmp_path):
    r = tool("study", "analyse", "--root", tmp_path / "none", check=False)
    assert r.returncode != 0, "analyse accepted a missing root"
    assert "no study results" in r.stderr, "unclear message for a missing study root"


def test_report_links_a_study_beside_the_run(tmp_path, make_fake_run, make_fake_study):
    make_fake_study(tmp_path / "study")
    tool("study", "analyse", "--root", tmp_path / "study")
    run_dir = make_fake_run(tmp_path / "paper")
    tool("report", run_dir)
    assert "](../study/study.md)" in read_text(os.path.join(run_dir, "report.md")), \
        "report.md does not link ../study/study.md"
