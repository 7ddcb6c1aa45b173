"""Every key a run writes into summary.json is listed by `celldem schema --summary --json` (run/summary_schema.hpp,
generated from the typed results' field tables), with its unit and meaning.

Small decks (150 spheres, tests to 0.2 % strain) cover every kind of test and extra: a graded sample with a
preparation; an axial test with strain probes and an adaptive rate, an extension test with a rate check, a simple
shear with stress probes, a principal-axis rotation, a stress-controlled test; a preparation from initial_state under
--tolerance; seeds. Each written key path (array indices dropped) must match a listed path, `*` in it standing for a
name of the run's choosing (a test, a probe point, a compared quantity).

Usage: CELLDEM=build/celldem /usr/bin/python3 -m pytest tests/run/test_summary_schema.py (ctest: run_summary_schema)
"""
import json
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
P0 = 1e5


def small_deck():
    with open(os.path.join(ROOT, "tests", "run", "small_run.json")) as f:
        deck = json.load(f)
    deck["tests"] = []
    deck["control_failure"] = "warn"
    return deck


def axial(name, inc=1e-6, **extra):
    t = {"name": name, "friction": 0.5, "output_interval": 100,
         "axes": {"x1": {"strain_increment": inc}, "x2": {"stress": P0}, "x3": {"stress": P0}},
         "end": {"axis": "x1", "strain": 0.002 if inc > 0 else -0.002}}
    t.update(extra)
    return t


def every_kind():
    deck = small_deck()
    deck["sample"]["diameters"] = {"grading": {"by": "mass", "sizes": [0.003, 0.0036, 0.0045],
                                               "passing": [0, 30, 100]}}
    deck["tests"] = [
        axial("axial", adaptive_rate={"max_factor": 4},
              probes={"at_e1": [0.001], "at": ["peak"], "kind": "strain", "magnitudes": [1e-5], "steps": 300,
                      "hold_steps": 100}),
        axial("extension", inc=-1e-6, verify_rate={"rate_factor": 0.5, "twin": True}),
        {"name": "shear", "friction": 0.5, "output_interval": 100, "simple_shear": {"gamma_increment": 2e-6,
                                                                                   "normal_stress": P0},
         "end": {"steps": 1000},
         "probes": {"at": ["peak"], "kind": "stress", "plane": "rendulic", "directions": 4, "magnitudes": [4000],
                    "steps": 300, "hold_steps": 100}},
        {"name": "rotation", "friction": 0.5, "output_interval": 100,
         "axes": {"x3": {"stress": P0}},
         "rotate_principal_axes": {"plane": "x1x2", "sigma1": 1.2e5, "sigma3": P0, "rate": 3e4},
         "end": {"steps": 800}},
        {"name": "stresses", "friction": 0.5, "output_interval": 100,
         "axes": {"x1": {"stress": 1.1e5}, "x2": {"stress": P0}, "x3": {"stress": P0}, "x12": {"stress": 2e3}},
         "end": {"steps": 500}}]
    return deck


def run(celldem, deck, folder, name, *extra):
    path = os.path.join(folder, name + ".json")
    with open(path, "w") as f:
        json.dump(deck, f)
    out = os.path.join(folder, name)
    r = subprocess.run([celldem, "run", path, "--out", out, "--quiet", *extra], capture_output=True, text=True,
                       env=dict(os.environ, OMP_NUM_THREADS="1"))
    assert r.returncode == 0, f"{name}: exit {r.returncode}: {r.stderr[-3000:]}"
    return out


def key_paths(x, prefix=""):
    """Every object key's path, array indices dropped. A dot inside a key (a probe point e1_0.001, a compared
    quantity end_window.Z) is written as "·", so that the key stays one part of the path, which `*` matches."""
    if isinstance(x, dict):
        for k, v in x.items():
            k = k.replace(".", "·")
            p = f"{prefix}.{k}" if prefix else k
            yield p
            yield from key_paths(v, p)
    elif isinstance(x, list):
        for v in x:
            yield from key_paths(v, prefix)


def listed(schema, path):
    parts = path.split(".")
    for entry in schema:
        keys = entry.replace("[]", "").split(".")
        if len(keys) == len(parts) and all(k in ("*", p) for k, p in zip(keys, parts)):
            return True
    return False


@pytest.fixture(scope="module")
def schema(celldem):
    r = subprocess.run([celldem, "schema", "--summary", "--json"], capture_output=True, text=True, check=True)
    entries = json.loads(r.stdout)
    for e in entries:
        assert e["meaning"], f"{e['key']}: no meaning"
    return [e["key"] for e in entries]


@pytest.fixture(scope="module")
def summaries(celldem, tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("summary_schema"))
    found = {}
    first = run(celldem, every_kind(), folder, "every_kind")
    found["every_kind"] = os.path.join(first, "summary.json")
    # A preparation from the first run's prepared sample under --tolerance (started_from, tolerance, resolved).
    deck = small_deck()
    deck["sample"]["diameters"] = every_kind()["sample"]["diameters"]  # the sample's own grading
    deck["initial_state"] = os.path.join(first, "prepared.state")
    deck["prepare"]["relax_overlaps"] = 0.01
    deck["tests"] = [axial("ttc")]
    found["tolerance"] = os.path.join(run(celldem, deck, folder, "tolerance", "--tolerance", "2"), "summary.json")
    # Seeds: each seed's own summary.
    deck = small_deck()
    deck["tests"] = [axial("ttc")]
    deck["energy_budget"] = True  # (its record)
    seeds = run(celldem, deck, folder, "seeds", "--seeds", "2")
    for sub in sorted(os.listdir(seeds)):
        if os.path.isfile(os.path.join(seeds, sub, "summary.json")):
            found["seeds/" + sub] = os.path.join(seeds, sub, "summary.json")
    return found


def test_every_written_key_is_listed(schema, summaries):
    missing = set()
    for name, path in summaries.items():
        with open(path) as f:
            summary = json.load(f)
        for p in key_paths(summary):
            if not listed(schema, p):
                missing.add(f"{p} ({name})")
    assert not missing, "summary.json keys missing from `celldem schema --summary`:\n  " + "\n  ".join(sorted(missing))


def test_the_runs_cover_every_kind(summaries):
    """The decks reach what the schema test needs: each kind's record, probes, a rate check, a tolerance, seeds."""
    with open(summaries["every_kind"]) as f:
        tests = json.load(f)["tests"]
    assert "probes" in tests["axial"] and "adaptive_rate" in tests["axial"]
    assert "verify_rate" in tests["extension"] and "extension" in tests["extension"]
    assert "shear" in tests["shear"] and "probes" in tests["shear"]
    assert "rotation" in tests["rotation"]
    with open(summaries["tolerance"]) as f:
        s = json.load(f)
    assert "tolerance" in s and "started_from" in s["prepared"]
    assert any(k.startswith("seeds/") for k in summaries)


def test_a_key_not_listed_is_caught(schema):
    """The check itself: a made-up key is not listed, a test's own key under any test name is."""
    assert not listed(schema, "tests.ttc.no_such_key")
    assert listed(schema, "tests.any_name.peak_state.sigma1")
    assert listed(schema, "tests.t.legs.control_errors.axes.last_reached")
