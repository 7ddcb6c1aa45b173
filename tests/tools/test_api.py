"""The public API (tools/celldem/api.py, docs/python.md) against a real small run of the binary: what open_run and
open_ensemble give is what celldem wrote (the CSV, series.columns.json, summary.json and ensemble.json read here
independently), Deck round trips, and check_deck / run_deck pass celldem's verdicts through."""

import csv
import json
import math
import os

import numpy as np
import pytest

import celldem as api
from celldem import binary
from checking import ROOT

SMALL_RUN = os.path.join(ROOT, "tests", "run", "small_run.json")
END_STRAIN = 0.002  # small_run.json's tests cut short: a run of a few seconds


def tiny_deck():
    with open(SMALL_RUN) as f:
        data = json.load(f)
    for test in data["tests"]:
        test["end"]["strain"] = END_STRAIN
    return data


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory, celldem):
    out = tmp_path_factory.mktemp("api") / "run"
    run = api.run_deck(api.Deck.from_dict(tiny_deck()), out, threads=1, celldem=celldem)
    return str(out), run


def read_csv(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    header, body = rows[0], rows[1:]
    return header, [[float(v) if v not in ("", "nan") else math.nan for v in row] for row in body]


def test_run_stages_and_tests(run_folder):
    out, run = run_folder
    assert isinstance(run, api.Run)
    assert list(run.stages) == ["prepare", "ttc", "psc"]
    assert list(run.tests) == ["ttc", "psc"]
    assert run.stages["ttc"] is run.tests["ttc"]


def test_series_is_the_csv_with_its_units(run_folder):
    out, run = run_folder
    for name, stage in run.stages.items():
        header, rows = read_csv(os.path.join(out, name, "series.csv"))
        df = stage.series
        assert list(df.columns) == header, f"{name}: columns are not the CSV header"
        assert len(df) == len(rows) > 1, f"{name}: {len(df)} rows, the CSV has {len(rows)}"
        np.testing.assert_array_equal(df.to_numpy(), np.array(rows), err_msg=f"{name}: values differ from the CSV")
        meta = json.load(open(os.path.join(out, name, "series.columns.json")))["columns"]
        assert df.attrs["units"] == {c["name"]: c["unit"] for c in meta if c["name"] in header}
        assert df.attrs["meanings"]["e1"] == next(c["meaning"] for c in meta if c["name"] == "e1")
    assert run.tests["ttc"].series.attrs["units"]["s11"] == "Pa"


def test_summary_and_deck_are_celldems(run_folder):
    out, run = run_folder
    summary = json.load(open(os.path.join(out, "summary.json")))
    assert run.summary == summary
    assert run.tests["psc"].summary == summary["tests"]["psc"]
    assert run.stages["prepare"].summary == summary["prepared"]
    # The test's peak is celldem's: the same as `celldem summarize` of its series.
    peak = binary.summarize(os.path.join(out, "ttc", "series.csv"))["peak_ratio13"]
    assert run.tests["ttc"].summary["peak_ratio13"] == pytest.approx(peak, rel=1e-12)
    assert run.tests["ttc"].series["e1"].iloc[-1] == pytest.approx(END_STRAIN, rel=1e-3)
    assert run.deck == tiny_deck(), "the deck celldem ran (progress.json) is not the deck given"


def test_open_run_refuses_a_folder_without_summary(tmp_path):
    with pytest.raises(FileNotFoundError, match="run directory not found"):
        api.open_run(tmp_path / "none")
    (tmp_path / "empty").mkdir()
    with pytest.raises(FileNotFoundError, match="summary.json not found"):
        api.open_run(tmp_path / "empty")


def test_run_deck_refuses_an_earlier_run_without_force(run_folder, celldem):
    out, run = run_folder
    with pytest.raises(api.DeckError, match="already holds results"):
        api.run_deck(tiny_deck(), out, threads=1, celldem=celldem)


def test_check_deck(celldem):
    assert "valid (150 particles, 2 tests" in api.check_deck(tiny_deck(), celldem=celldem)
    bad = tiny_deck()
    bad["sample"]["count"] = -5
    with pytest.raises(api.DeckError, match=r"sample\.count"):
        api.check_deck(bad, celldem=celldem)
    bad = tiny_deck()
    bad["samples"] = bad.pop("sample")
    with pytest.raises(api.DeckError, match="invalid deck: sample: missing required key"):
        api.check_deck(bad, celldem=celldem)
    assert not [f for f in os.listdir(os.getcwd()) if f.startswith(".celldem-deck-")], "a temporary deck was left"


def test_deck_round_trip_and_relative_paths(run_folder, celldem, tmp_path):
    """A deck's relative paths resolve from its own folder, as `celldem check FILE` resolves them."""
    out, run = run_folder
    data = tiny_deck()
    deck = api.Deck.from_dict(data)
    data["sample"]["count"] = 1
    assert deck["sample"]["count"] == 150, "from_dict does not copy"
    from_state = deck.to_dict()
    from_state.pop("prepare")
    from_state["initial_state"] = "prepared.state"
    path = os.path.join(out, "from_state.json")
    api.Deck.from_dict(from_state).save(path)
    loaded = api.Deck.load(path)
    assert loaded.to_dict() == from_state and loaded.directory == out
    assert "valid" in api.check_deck(loaded, celldem=celldem)
    elsewhere = api.Deck.from_dict(from_state, directory=tmp_path)
    with pytest.raises(api.DeckError, match="initial_state"):
        api.check_deck(elsewhere, celldem=celldem)
    os.remove(path)


def test_run_deck_fails_with_celldems_exit(celldem, tmp_path):
    """A run that fails while running (a stress no packing carries: its control fails) raises RunFailed with exit
    1; a run folder that is a file is refused before the run, exit 2 (DeckError)."""
    deck = tiny_deck()
    for test in deck["tests"]:
        test["axes"]["x2"] = {"stress": 1.0e8}  # (1e12 Pa overlaps the spheres by 1000 diameters: refused, exit 2)
        test["end"]["strain"] = 0.006
    with pytest.raises(api.RunFailed, match="x2") as caught:
        api.run_deck(deck, tmp_path / "fails", threads=1, celldem=celldem)
    assert caught.value.returncode == 1
    blocked = tmp_path / "blocked"
    blocked.write_text("not a folder\n")
    with pytest.raises(api.DeckError, match="not a folder") as refused:
        api.run_deck(tiny_deck(), blocked, threads=1, celldem=celldem)


def test_open_ensemble(tmp_path, celldem):
    ens = api.run_deck(tiny_deck(), tmp_path / "ens", threads=1, seeds="1-2", celldem=celldem)
    assert isinstance(ens, api.Ensemble)
    statistics = json.load(open(tmp_path / "ens" / "ensemble.json"))
    assert ens.statistics == statistics
    assert ens.seeds == statistics["seeds"] == [1, 2]
    assert sorted(ens.runs) == [1, 2]
    for seed, run in ens.runs.items():
        assert run.directory == str(tmp_path / "ens" / f"seed-{seed}")
        assert list(run.tests) == ["ttc", "psc"] and len(run.tests["ttc"].series) > 1
    # ensemble.json's mean is the mean of the seeds' summary.json values.
    ev = [run.tests["ttc"].summary["ev_final"] for run in ens.runs.values()]
    assert ev[0] != ev[1], "two seeds gave the same run"
    assert statistics["tests"]["ttc"]["ev_final"]["mean"] == pytest.approx(np.mean(ev), rel=1e-9)
    assert api.open_ensemble(tmp_path / "ens").seeds == [1, 2]
    with pytest.raises(FileNotFoundError, match="ensemble.json not found"):
        api.open_ensemble(tmp_path / "ens" / "seed-1")


def test_every_option_of_celldem_run_is_a_keyword_of_run_deck(celldem):
    """`celldem run --help`'s options (but --out, given as `out`, and --help) are run_deck's keywords, each
    keyword-only, and run_command turns each into its flag."""
    import inspect
    import re
    import subprocess

    text = subprocess.run([celldem, "run", "--help"], capture_output=True, text=True, check=True).stdout
    flags = set(re.findall(r"^\s+(?:-\w,)?--([a-z][a-z-]*)", text, flags=re.M)) - {"help", "out"}
    assert len(flags) >= 10, f"parsed too few options from `celldem run --help`: {sorted(flags)}"
    parameters = inspect.signature(api.run_deck).parameters
    keywords = {name.replace("_", "-") for name, p in parameters.items() if p.kind is p.KEYWORD_ONLY}
    assert flags <= keywords, f"options of `celldem run` that run_deck cannot pass: {sorted(flags - keywords)}"
    values = {"threads": 2, "seeds": "1-2", "tolerance": 1.5,
              "verify_rate_factor": 0.25, "floors": "f.json", "probes": "1-9", "progress_interval": 5.0}
    options = {name.replace("-", "_"): values.get(name.replace("-", "_"), True) for name in flags}
    options.pop("resume")  # (excludes force)
    cmd = binary.run_command("d.json", "out", binary=celldem, **{k: v for k, v in options.items()
                                                                 if k not in ("threads", "seeds", "force", "quiet")},
                             threads=2, seeds="1-2", force=True, quiet=True)
    for name in flags - {"resume"}:
        assert "--" + name in cmd, f"--{name} missing from {cmd}"
    assert cmd[cmd.index("--verify-rate-factor") + 1] == "0.25" and cmd[cmd.index("--tolerance") + 1] == "1.5"


def test_run_deck_options_are_keyword_only_and_checked(celldem, tmp_path):
    with pytest.raises(TypeError):
        api.run_deck(tiny_deck(), tmp_path / "x", 2)  # threads positionally
    with pytest.raises(ValueError, match="no_verify_twin need verify_rate"):
        api.run_deck(tiny_deck(), tmp_path / "x", no_verify_twin=True, celldem=celldem)
    with pytest.raises(ValueError, match="exclude each other"):
        api.run_deck(tiny_deck(), tmp_path / "x", force=True, resume=True, celldem=celldem)


def test_the_binary_is_found_through_celldem_then_path(tmp_path, monkeypatch):
    """$CELLDEM first, then celldem on PATH, then the checkout's build; with none, the error lists each."""
    fake = tmp_path / "bin" / "celldem"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\necho '{\"fake\": true}'\n")
    fake.chmod(0o755)
    monkeypatch.delenv("CELLDEM", raising=False)
    monkeypatch.setenv("PATH", str(fake.parent))
    assert binary.find() == str(fake)
    other = tmp_path / "other"
    other.write_text("#!/bin/sh\n")
    other.chmod(0o755)
    monkeypatch.setenv("CELLDEM", str(other))
    assert binary.find() == str(other)
    monkeypatch.setenv("CELLDEM", str(tmp_path / "missing"))
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    monkeypatch.setattr(binary, "BUILT", str(tmp_path / "no-build" / "celldem"))
    with pytest.raises(binary.BinaryError) as err:
        binary.require()
    message = str(err.value)
    assert str(tmp_path / "missing") in message and "celldem on PATH" in message
    assert str(tmp_path / "no-build" / "celldem") in message or not binary.CHECKOUT


def test_constants_come_from_the_solver(celldem):
    """`celldem schema --constants`: the limits the tools judge runs by, with what each bounds."""
    known = binary.constants(celldem)
    assert 0 < binary.constant("quasi_static_inertial_number", celldem) < 1
    assert 0 < binary.constant("servo_tolerance", celldem) < 1
    assert "not a standard deviation" in known["servo_tolerance"]["meaning"]
    with pytest.raises(KeyError, match="servo_tolerance"):
        binary.constant("no_such_limit", celldem)
    # the stress probe planes' unit bases (solver/run/probes.cpp plane_basis): orthonormal; Rendulic's u1 along
    # axis 1 and u2 along 2 and 3 alike; the pi plane's both deviatoric, u1 triaxial compression
    planes = known["probe_planes"]["value"]
    assert sorted(planes) == ["pi", "rendulic"] and "cos a u1 + sin a u2" in known["probe_planes"]["meaning"]
    for basis in planes.values():
        u1, u2 = np.array(basis["u1"]), np.array(basis["u2"])
        assert np.allclose([u1 @ u1, u2 @ u2, u1 @ u2], [1.0, 1.0, 0.0], atol=1e-15)
    assert planes["rendulic"]["u1"] == [1.0, 0.0, 0.0] and planes["rendulic"]["u2"][1] == planes["rendulic"]["u2"][2]
    assert abs(sum(planes["pi"]["u1"])) < 1e-15 and abs(sum(planes["pi"]["u2"])) < 1e-15
    assert planes["pi"]["u1"][0] > 0 and planes["pi"]["u1"][1] == planes["pi"]["u1"][2]
