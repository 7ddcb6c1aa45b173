"""tools/sufficiency.py (tools/celldem/study/sufficiency.py): the switches' decks (linear equivalents at the mean
contact force, unused keys removed, drag kept, every variant accepted by celldem), the change measure and its
verdicts on known numbers; then a real run of the tool on a small scene of inputs/paper.json (100 spheres, tests to
ε1 = 4 %, past most peaks; a peak at a test's end is left out and listed, 2 seeds, about 10 s): sufficiency.json and
sufficiency.md, the switches the paper deck does not use reported as skipped; a switch that changes nothing
physical is never needed; and that `study.py analyse` includes the table in the study's report."""

import json
import math
import os
import re
import shutil
import subprocess

import pytest
import scipy.stats

from celldem import binary, decks
from celldem.study import sufficiency as su
from checking import ROOT, check, read_text, tool

PAPER = os.path.join(ROOT, "inputs", "paper.json")


@pytest.fixture(scope="module")
def rolling(celldem):
    return su.reduce_deck(decks.load(os.path.join(ROOT, "inputs", "rolling.json")), 300, 0.04)


@pytest.fixture(scope="module")
def mean_contact(rolling, celldem):
    return su.mean_contact(binary.plan_deck(rolling, None, celldem))


@pytest.fixture(scope="module")
def configs(rolling, celldem):
    return {key: (vdeck, info) for key, _, vdeck, info in su.variants(rolling, celldem)}


def test_reduce_deck(rolling):
    check("reduced count", rolling["sample"]["count"], 300)
    check("reduced end strains", [t["end"]["strain"] for t in rolling["tests"]], [0.04, 0.04])


def test_mean_contact_from_plan(mean_contact):
    # The mean contact at 100 kPa from `celldem plan`, against a hand calculation: F = pi d^2 p / 3.6, Hertz overlap
    # of two mean spheres (R* = d/4).
    d, p, e, nu = 3.75e-3, 1.0e5, 7.0e10, 0.25
    force = math.pi * d * d * p / 3.6
    e_star, g_star = e / (2 * (1 - nu * nu)), e / (4 * (2 - nu) * (1 + nu))
    overlap = (3 * force / (4 * e_star * math.sqrt(d / 4))) ** (2 / 3)
    cm = mean_contact
    check("confining stress", cm["pressure"], p)
    check("mean diameter", cm["mean_diameter"], d, 1e-12)
    check("mean force", cm["force"], force, 1e-12)
    check("hertz overlap", cm["overlap"], overlap, 1e-12)
    check("secant kn", cm["kn_secant"], force / overlap, 1e-12)
    check("mindlin kt", cm["kt_mindlin"], 8 * g_star * math.sqrt(d / 4 * overlap), 1e-12)


def test_switch_decks(configs, mean_contact, rolling, celldem):
    cm = mean_contact
    e, nu = 7.0e10, 0.25
    check("rolling deck: every switch applies", sorted(k for k, (v, _) in configs.items() if v is None), [])
    n, t, r, w = (configs[k][0]["contact"] for k in ("normal", "tangential", "rolling", "twisting"))
    check("normal → linear", n["normal"], "linear")
    check("secant kn set", n["kn"], cm["kn_secant"], 1e-12)
    check("tangential → linear_history", t["tangential"], "linear_history")
    check("mindlin kt set", t["kt"], cm["kt_mindlin"], 1e-12)
    check("rolling → none, its keys gone", (r["rolling"], sorted(k for k in r if k.startswith("rolling_"))),
          ("none", []))
    check("rolling → none, the tests' rolling friction gone",
          [k for t in configs["rolling"][0]["tests"] for k in t if k == "rolling_friction"], [])
    check("normal → linear keeps E and nu for mindlin", (n["youngs_modulus"], n["poisson_ratio"]), (e, nu))
    check("tangential → linear_history keeps E and nu for hertz", (t["youngs_modulus"], t["poisson_ratio"]), (e, nu))
    both = json.loads(json.dumps(rolling))
    both["contact"].update(normal="linear", tangential="linear_history", kn=1e6, kt=1e6)
    both = su.clean(both, binary.schema(celldem))
    check("clean: no E, nu or reference overlap without hertz and mindlin",
          sorted(k for k in ("youngs_modulus", "poisson_ratio", "reference_overlap") if k in both["contact"]), [])
    check("twisting → none", (w["twisting"], w["rolling"]), ("none", "sds"))
    check("rotational damping → 0", configs["rotational_damping"][0]["damping"]["rotational"], 0.0)
    check("kinematics → lammps", configs["kinematics"][0]["kinematics"], "lammps")
    check("normal switch rescales the damping", configs["normal"][1]["damping_factors"]["translational"] > 1.5, True)


def test_every_switch_deck_is_accepted_and_keeps_drag(configs, rolling, celldem, tmp_path):
    base_plan = binary.plan_deck(rolling, None, celldem)["particle_types"][0]
    for key, (vdeck, info) in configs.items():
        if vdeck is None:
            continue
        path = os.path.join(tmp_path, f"{key}.json")
        decks.write(path, vdeck)
        r_ = subprocess.run([celldem, "check", path], capture_output=True, text=True)
        assert r_.returncode == 0, f"celldem check refuses the {key} variant: {r_.stderr.strip()}"
        if key in ("normal", "tangential"):  # a contact-law switch keeps the baseline's drag coefficients
            vp = binary.plan_deck(vdeck, None, celldem)["particle_types"][0]
            check(f"{key}: translational drag kept", vp["translational_drag"], base_plan["translational_drag"], 1e-9)
            check(f"{key}: rotational drag kept", vp["rotational_drag"], base_plan["rotational_drag"], 1e-9)


def test_paper_deck_skips_the_switches_it_does_not_use(celldem):
    paper = decks.load(PAPER)
    skipped = {k: i.get("skipped") for k, _, v, i in su.variants(su.reduce_deck(paper, 40, 0.005), celldem)
               if v is None}
    check("paper deck: skipped switches", sorted(skipped), ["normal", "rolling", "tangential", "twisting"])
    check("skip reason", skipped["normal"], "skipped: normal is linear")
    check("b only for the non-axisymmetric test", [q for q in su.quantities_of(paper) if q[1] == "b_peak"],
          [("psc", "b_peak")])


def test_change_measure_and_verdicts():
    # Paired differences per seed, paired t, TOST within a noise floor; verdicts by judge_switch.
    floor = 1.0
    c = su.change([2.0, 2.1, 1.9, 2.05], floor)
    check("delta", c["delta"], 2.0125, 1e-12)
    check("noise units", c["noise_units"], 2.0125, 1e-12)
    check("margin: the floor's lower 97.5 % limit", c["margin"], math.sqrt(3 / scipy.stats.chi2.ppf(0.975, 3)), 1e-12)
    check("verdict needed", su.judge_switch({"a": c}), "needed")
    check("quantity changes", c["verdict"], "changes")
    check("verdict not needed", su.judge_switch({"a": su.change([0.01, -0.02, 0.0, 0.01], floor)}), "not needed")
    check("undecided", su.judge_switch({"a": su.change([1.5, -1.4, 0.9, -0.2], floor)}), "undecided at 4 seeds")
    check("no spread", su.change([1.0, 2.0], 0.0)["margin"], None)
    check("no values", su.change([], 1.0), None)
    check("paired by seed", su.paired({1: 1.0, 2: 2.0, 3: 5.0}, {2: 2.5, 1: 0.5}), [-0.5, 0.5])


def test_run_metrics_prefer_the_robust_peak():
    # Robust peak fields when summary.json has them, the plain ones otherwise.
    info = {"peak_ratio13": 3.0, "e1_at_peak": 0.01, "b_at_peak": 0.4, "final_e1": 0.03,
            "end_window": {"ev": -0.02, "Z": 4.4}, "peak_robust": {"ratio13": 2.9, "e1": 0.012, "b_mean": 0.38}}
    m = su.run_metrics({"tests": {"psc": info}}, 0.03)["psc"]
    check("robust peak", (m["peak_ratio"], m["e1_peak"], m["b_peak"], m["ev_end"], m["Z_end"]),
          (2.9, 0.012, 0.38, -0.02, 4.4))
    info.pop("peak_robust")
    check("plain peak", su.run_metrics({"tests": {"psc": info}}, 0.03)["psc"]["peak_ratio"], 3.0)


TINY = ("--seeds", "2", "--count", "100", "--end-strain", "0.04")


@pytest.fixture(scope="module")
def tiny(tmp_path_factory, celldem):
    """The tool on a tiny scene of the paper deck (2 seeds)."""
    out = str(tmp_path_factory.mktemp("sufficiency") / "sufficiency-tiny")
    tool("sufficiency", PAPER, "--out", out, *TINY, "--celldem", celldem)
    return out


def test_tiny_scene_writes_its_files(tiny):
    for f in ("sufficiency.json", "sufficiency.md"):
        path = os.path.join(tiny, f)
        assert os.path.isfile(path) and os.path.getsize(path) > 0, f"no {f}"


def test_tiny_scene_results(tiny):
    r = json.load(open(f"{tiny}/sufficiency.json"))
    check("seeds", r["seeds"], [1, 2])
    check("scene", (r["scene"]["count"], r["scene"]["end_strain"]), (100, 0.04))
    qs = ["ttc.peak_ratio", "ttc.e1_peak", "ttc.ev_end", "ttc.Z_end",
          "psc.peak_ratio", "psc.e1_peak", "psc.ev_end", "psc.Z_end", "psc.b_peak"]
    check("quantities", r["quantities"], qs)
    rows = {x["key"]: x for x in r["rows"]}
    check("rows", [x["key"] for x in r["rows"]],
          ["baseline", "normal", "tangential", "rolling", "twisting", "rotational_damping", "kinematics"])
    for k in ("normal", "tangential", "rolling", "twisting"):
        assert rows[k]["verdict"].startswith("skipped"), \
            f"{k} should be skipped for the paper deck, verdict {rows[k]['verdict']!r}"
    for k in ("rotational_damping", "kinematics"):
        row = rows[k]
        check(f"{k} seeds", row.get("seeds"), [1, 2])
        assert row["verdict"] in ("needed", "not needed", "undecided at 2 seeds",
                                  "undetermined (fewer than 2 paired seeds)"), \
            f"{k}: verdict {row['verdict']!r}"
        check(f"{k} quantities", sorted(row["changes"]), sorted(qs))
        c = row["changes"]["ttc.peak_ratio"]
        # The seeds whose TTC reached its peak in both runs (a peak at the test's end is left out).
        peaked = [s for s in (1, 2)
                  if f"baseline_s{s}: ttc" not in r["no_peak"] and f"{k}_s{s}: ttc" not in r["no_peak"]]
        assert c is not None and c["n"] == len(peaked) and row["changes"]["ttc.ev_end"]["n"] == 2, \
            f"{k}: TTC changes over the paired seeds missing: {c}"
        if c["p_holm"] is not None:
            equivalent = c["p_tost"] is not None and c["p_tost"] <= r["tost_alpha"]
            want = "within margin" if equivalent else "changes" if c["p_holm"] <= r["alpha"] else "undecided"
            check(f"{k} TTC peak verdict follows its tests", c["verdict"], want)
        needed = [q for q, c in row["changes"].items() if c and c["verdict"] == "changes"]
        check(f"{k} needed_for", row["needed_for"], needed)
        check(f"{k} verdict", row["verdict"] == "needed", bool(needed))
    for q in qs:
        no_peak = all(f"baseline_s{s}: {q.split('.')[0]}" in r["no_peak"] for s in (1, 2))
        assert r["noise_floor"][q]["mean"] is not None or \
            (no_peak and q.split(".")[1] in ("peak_ratio", "e1_peak", "b_peak")), f"no baseline mean of {q}"
    check("failed runs", r["failed"], [])
    check("runs counted", r["cost"]["runs"], 2 + 3 * 2)
    assert r["cost"]["cpu_s"] > 0 and r["cost"]["wall_s"] > 0, f"cost missing: {r['cost']}"
    md = read_text(f"{tiny}/sufficiency.md")
    for needle in ("# Model sufficiency: ", "| switch | seeds | verdict | TTC peak σ1/σ3 |", "PSC b at peak |",
                   "| normal: hertz → linear | — | skipped: normal is linear |",
                   "| twisting: marshall → none | — | skipped: twisting is none |",
                   "| baseline: mean (noise floor) | 1,2 |", "| rotational damping → 0 | 1,2 |", "Holm",
                   "TOST", "Cost: 8 runs"):
        assert needle in md, f"sufficiency.md lacks {needle!r}"


def test_second_call_runs_nothing_again(tiny, celldem):
    r = tool("sufficiency", PAPER, "--out", tiny, *TINY, "--celldem", celldem)
    first = (r.stdout + r.stderr).splitlines()[0]
    assert "0 runs to do of 8" in r.stdout + r.stderr, f"a second call ran again: {first}"


def test_round_off_switch_is_never_needed(tmp_path, celldem):
    """Calibration: a switch that changes nothing physical (time_step x (1 + 1e-9)) is never needed."""
    null = str(tmp_path / "sufficiency-null")
    tool("sufficiency", PAPER, "--out", null, "--seeds", "3", "--count", "40", "--end-strain", "0.005",
         "--switches", "round_off", "--celldem", celldem)
    r = json.load(open(f"{null}/sufficiency.json"))
    rows = {x["key"]: x for x in r["rows"]}
    check("rows", sorted(rows), ["baseline", "round_off"])
    row = rows["round_off"]
    check("seeds", row["seeds"], [1, 2, 3])
    assert row["verdict"] != "needed", f"a round-off switch is called needed for {row['needed_for']}"
    # Stronger: every quantity with at least two paired seeds is equivalent to no change within the margin
    # (TOST), so the switch is "not needed"; the peak quantities of tests that one seed at most took past their
    # peak by 0.5 % are untested, not undecided.
    changes = {k: c for k, c in row["changes"].items() if c}
    untested = sorted(k for k, c in changes.items() if c["n"] < 2)
    check("untested quantities", sorted(k for k, c in changes.items() if c["verdict"] == "untested"), untested)
    assert len(untested) < len(changes), "nothing was tested"
    check("verdict", row["verdict"], "not needed")
    units = [abs(c["noise_units"]) for c in changes.values() if c["noise_units"] is not None]
    print(f"  round_off: {row['verdict']}; largest |change| {max(units):.2g} noise floors; untested {untested}")


def test_one_seed_is_refused(tmp_path, celldem):
    r = tool("sufficiency", PAPER, "--out", tmp_path / "x", "--seeds", "1", "--celldem", celldem, check=False)
    assert r.returncode != 0, "one seed accepted (no noise floor)"


def test_study_report_includes_the_sufficiency_table(tiny, tmp_path, make_fake_study):
    """The study's report includes the sufficiency.md of a folder named sufficiency* beside the study root; without
    any sufficiency results there is no section."""
    root = make_fake_study(tmp_path / "study")
    beside = tmp_path / "sufficiency-tiny"
    shutil.copytree(tiny, beside)
    tool("study", "analyse", "--root", root)
    md = read_text(os.path.join(root, "study.md"))
    assert re.search(r"^## Model sufficiency$", md, re.M), "study.md has no Model sufficiency section"
    assert re.search(r"^### Model sufficiency: .*paper.json$", md, re.M), "study.md does not include the table"
    assert "| normal: hertz → linear | — | skipped: normal is linear |" in md, "study.md lacks the table's rows"
    shutil.rmtree(beside)
    tool("study", "analyse", "--root", root)
    assert "Model sufficiency" not in read_text(os.path.join(root, "study.md")), \
        "a section without any sufficiency results"
