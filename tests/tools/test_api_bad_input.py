"""The public API (tools/celldem/api.py) on bad input and interruptions: each fault gives a clear answer naming the
file, key or parameter, and nothing is left behind.

- run_deck stopped (SIGTERM from a batch system's time limit, SIGINT, SIGKILL) leaves no celldem running and, but
  for SIGKILL, no temporary deck file;
- run_deck(seeds="3"), one seed of a job array, returns the share's run;
- a test whose series.csv is missing stays in Run.tests, damaged, instead of vanishing;
- a program that is not celldem (/bin/true exits 0) is refused, naming its path;
- a file that is not JSON (ensemble.json, a deck, summary.json, ...) raises FileFormatError or DeckError naming
  the file, the line and the column, never a bare JSONDecodeError;
- a deck given as a path is loaded; a list or another type is a TypeError naming the parameter.
"""

import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time

import pytest

import celldem as api
from celldem import api as api_module, binary, decks, files, results
from checking import ROOT, TOOLS

SMALL_RUN = os.path.join(ROOT, "tests", "run", "small_run.json")


def small_deck(end_strain=0.002):
    with open(SMALL_RUN) as f:
        data = json.load(f)
    for test in data["tests"]:
        test["end"]["strain"] = end_strain
    return data


def temporary_decks(folder):
    return [f for f in os.listdir(folder) if f.startswith(".celldem-deck-")]


# ---- 1. run_deck stopped: no celldem left running, no temporary deck left behind ---------------------------------

RUNNER = textwrap.dedent("""
    import json, sys
    import celldem
    deck_file, deck_dir, out, binary = sys.argv[1:5]
    with open(deck_file) as f:
        deck = celldem.Deck.from_dict(json.load(f), directory=deck_dir)
    celldem.run_deck(deck, out, threads=1, celldem=binary)
""")


def processes_running(marker):
    """The pids of running processes (not zombies) whose command line holds `marker`."""
    pids = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmdline = f.read().decode(errors="replace")
            with open(f"/proc/{pid}/stat") as f:
                state = f.read().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if marker in cmdline and state != "Z":
            pids.append(int(pid))
    return pids


def wait_for(condition, timeout):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.05)
    return condition()


@pytest.fixture
def long_run(tmp_path, celldem):
    """A Python script inside run_deck on a deck that runs for minutes: (its Popen, the deck's folder, whose path
    only celldem's command line holds); celldem has started. Any celldem left is killed afterwards."""
    deck_dir = tmp_path / "deck-folder"
    deck_dir.mkdir()
    deck_file = tmp_path / "long.json"
    deck_file.write_text(json.dumps(small_deck(end_strain=0.3)))
    script = tmp_path / "runner.py"
    script.write_text(RUNNER)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([TOOLS] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
    proc = subprocess.Popen([sys.executable, str(script), str(deck_file), str(deck_dir), str(tmp_path / "out"),
                             celldem], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    marker = str(deck_dir) + os.sep
    try:
        started = wait_for(lambda: processes_running(marker) or proc.poll() is not None, 60)
        assert started and proc.poll() is None, f"run_deck did not start celldem: {proc.communicate()}"
        assert temporary_decks(deck_dir), "no temporary deck while celldem runs"
        time.sleep(0.5)  # (into the run: the script waits in run_deck)
        yield proc, deck_dir
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        for pid in processes_running(marker):
            os.kill(pid, signal.SIGKILL)


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_stopped_script_stops_celldem_and_removes_the_deck(long_run, sig):
    """SIGTERM (a batch system's time limit) or SIGINT to the script alone: celldem stops with it and the temporary
    deck is gone; SIGTERM still ends the script as SIGTERM does."""
    proc, deck_dir = long_run
    proc.send_signal(sig)
    try:
        proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail(f"the script did not end within 60 s of {sig.name}")
    stderr = proc.stderr.read()
    if sig == signal.SIGTERM:
        assert proc.returncode == -signal.SIGTERM, f"exit {proc.returncode}: {stderr[-2000:]}"
    else:
        assert proc.returncode != 0 and "KeyboardInterrupt" in stderr, stderr[-2000:]
    marker = str(deck_dir) + os.sep
    assert wait_for(lambda: not processes_running(marker), 10), \
        f"celldem still runs after the script ended by {sig.name}: pids {processes_running(marker)}"
    assert not temporary_decks(deck_dir), f"the temporary deck stayed after {sig.name}: {temporary_decks(deck_dir)}"


def test_a_killed_script_does_not_leave_celldem_running(long_run):
    """SIGKILL, which no handler sees: celldem gets SIGTERM at its parent's death (binary.start) and stops."""
    proc, deck_dir = long_run
    proc.kill()
    proc.wait()
    marker = str(deck_dir) + os.sep
    assert wait_for(lambda: not processes_running(marker), 30), \
        f"celldem outlived its killed script: pids {processes_running(marker)}"


def test_run_deck_leaves_no_temporary_deck(celldem, tmp_path):
    deck = api.Deck.from_dict(small_deck(), directory=tmp_path)
    with pytest.raises(api.DeckError):
        api.run_deck(deck, tmp_path / "out", threads=1, seeds="x", celldem=celldem)
    assert not temporary_decks(tmp_path), "a refused run left its temporary deck"


# ---- 2. one seed of a job array ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def share(tmp_path_factory, celldem):
    out = tmp_path_factory.mktemp("share") / "ens"
    return out, api.run_deck(small_deck(), out, threads=1, seeds="3", celldem=celldem)


def test_one_seed_returns_the_shares_run(share):
    """`celldem run --seeds 3` writes out/seed-3/ and no ensemble.json (`celldem merge` gathers shares): run_deck
    returns that run."""
    out, run = share
    assert not (out / "ensemble.json").exists()
    assert isinstance(run, api.Run)
    assert run.directory == str(out / "seed-3")
    assert list(run.tests) == ["ttc", "psc"] and len(run.tests["ttc"].series) > 1
    assert run.deck["sample"]["seed"] == 3


def test_one_seed_is_told_from_a_list():
    for one in ("3", "3-3", "3,3", " 3 "):
        assert api_module._one_seed(one) == 3, one
    for many in ("1-2", "1,3", "1-8", "3,4-4"):
        assert api_module._one_seed(many) is None, many


# ---- 3. a damaged test stays visible -------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def run_folder(tmp_path_factory, celldem):
    """A whole run of the small deck (to copy and damage)."""
    out = tmp_path_factory.mktemp("whole") / "run"
    api.run_deck(small_deck(), out, threads=1, celldem=celldem)
    return out


def test_a_test_without_its_series_is_damaged_not_dropped(run_folder, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(run_folder, folder)
    csv = folder / "ttc" / "series.csv"
    os.remove(csv)
    run = api.open_run(folder)
    assert list(run.tests) == ["ttc", "psc"], "the damaged test vanished"
    assert run.tests["ttc"].damaged and str(csv) in run.tests["ttc"].damaged
    assert run.damaged == {"ttc": run.tests["ttc"].damaged}
    assert run.tests["ttc"].summary["peak_ratio13"] is not None, "the damaged test's summary is still there"
    assert "damaged" in repr(run) and "ttc" in repr(run)
    with pytest.raises(FileNotFoundError, match=str(csv)):
        run.tests["ttc"].series
    assert run.tests["psc"].damaged is None and len(run.tests["psc"].series) > 1
    # The tools' view leaves it out, with a warning naming the file.
    with pytest.warns(UserWarning, match=str(csv)):
        arrays = results.load_run(folder)
    assert arrays.test_names == ["psc"]


# ---- 4. a binary that is not celldem -------------------------------------------------------------------------------

def test_a_program_that_is_not_celldem_is_refused(celldem, tmp_path):
    with pytest.raises(binary.BinaryError, match="/bin/true is not the celldem binary"):
        api.check_deck(small_deck(), celldem="/bin/true")
    silent = tmp_path / "silent"
    silent.write_text("#!/bin/sh\nexit 0\n")
    silent.chmod(0o755)
    with pytest.raises(binary.BinaryError, match=f"{silent} is not the celldem binary.*printed nothing"):
        api.run_deck(small_deck(), tmp_path / "out", threads=1, celldem=silent)
    assert not (tmp_path / "out").exists()
    liar = tmp_path / "liar"
    liar.write_text("#!/bin/sh\necho 'celldem-like 1.0'\n")
    liar.chmod(0o755)
    with pytest.raises(binary.BinaryError, match="celldem-like 1.0"):
        binary.plan(SMALL_RUN, liar)
    with pytest.raises(binary.BinaryError, match="cannot be run"):
        api.check_deck(small_deck(), celldem=tmp_path)  # a folder
    # celldem itself, and a program that runs it (a wrapper), are believed.
    version = subprocess.run([celldem, "--version"], capture_output=True, text=True, check=True).stdout.split()[1]
    assert binary.identify(celldem) == version
    wrapper = tmp_path / "wrapper"
    wrapper.write_text(f'#!/bin/sh\nexec "{celldem}" "$@"\n')
    wrapper.chmod(0o755)
    assert "valid" in api.check_deck(small_deck(), celldem=wrapper)


# ---- 5. files that are not JSON ------------------------------------------------------------------------------------

def assert_names_the_file(err, path, where="line 1 column"):
    assert isinstance(err, api.FileFormatError) and not isinstance(err, json.JSONDecodeError)
    assert str(path) in str(err) and where in str(err), str(err)


def test_a_damaged_ensemble_json_is_named(tmp_path):
    folder = tmp_path / "ens"
    folder.mkdir()
    path = folder / "ensemble.json"
    path.write_text('{"seeds": [1, 2],\n "tests": {oops}}\n')
    with pytest.raises(api.FileFormatError) as caught:
        api.open_ensemble(folder)
    assert_names_the_file(caught.value, path, "line 2 column")
    path.write_text("")
    with pytest.raises(api.FileFormatError, match="empty"):
        api.open_ensemble(folder)
    path.write_text("[1, 2]")
    with pytest.raises(api.FileFormatError, match=f"{path}: top level is an array, not a JSON object"):
        api.open_ensemble(folder)
    path.write_text('{"seeds": "1-2"}')
    with pytest.raises(api.FileFormatError, match='"seeds" is a string'):
        api.open_ensemble(folder)
    with pytest.raises(results.RunError, match=str(path)):  # the tools' reader passes it on
        results.load_ensemble(folder)


def test_a_deck_file_that_is_not_json_is_named(tmp_path):
    path = tmp_path / "deck.json"
    path.write_text('{"format": 1,\n  "sample": {"count": 150,}\n}\n')
    with pytest.raises(api.DeckError, match=f"{path}: not JSON: .* at line 2 column 27") as caught:
        api.Deck.load(path)
    assert not isinstance(caught.value, json.JSONDecodeError)
    with pytest.raises(api.FileFormatError) as caught:
        decks.load(path)
    assert_names_the_file(caught.value, path, "line 2 column 27")
    path.write_text("[1, 2]\n")
    with pytest.raises(api.DeckError, match=f"{path}: a deck is a JSON object, and the file holds an array"):
        api.Deck.load(path)
    path.write_bytes(b'{"format": "\xff"}')
    with pytest.raises(api.DeckError, match="not UTF-8"):
        api.Deck.load(path)
    with pytest.raises(FileNotFoundError, match="missing.json"):
        api.Deck.load(tmp_path / "missing.json")


def test_a_run_folders_damaged_json_is_named(run_folder, tmp_path):
    for name in ("summary.json", "progress.json", os.path.join("ttc", "series.columns.json")):
        folder = tmp_path / name.replace(os.sep, "-")
        shutil.copytree(run_folder, folder)
        path = folder / name
        path.write_text('{"truncated": ')
        with pytest.raises(api.FileFormatError) as caught:
            api.open_run(folder).tests["ttc"].series
        assert_names_the_file(caught.value, path)
    folder = tmp_path / "summary-array"
    shutil.copytree(run_folder, folder)
    (folder / "summary.json").write_text("[]")
    with pytest.raises(api.FileFormatError, match="top level is an array"):
        api.open_run(folder)


def test_read_json_is_none_only_for_a_missing_file(tmp_path):
    assert files.read_json(tmp_path / "missing.json") is None
    path = tmp_path / "bad.json"
    path.write_text("{")
    with pytest.raises(files.FileFormatError) as caught:
        files.read_json(path)
    assert_names_the_file(caught.value, path)
    assert caught.value.path == str(path) and caught.value.problem.startswith("not JSON")
    path.write_text('{"a": [1, 2.5]}')
    assert files.read_json(path) == files.load_json(path) == {"a": [1, 2.5]}


# ---- 6. a deck as a path; other types refused ----------------------------------------------------------------------

def test_a_deck_path_is_loaded_and_other_types_refused(celldem, tmp_path):
    from pathlib import Path

    path = tmp_path / "deck.json"
    path.write_text(json.dumps(small_deck()))
    for given in (str(path), Path(path)):
        assert "valid (150 particles, 2 tests" in api.check_deck(given, celldem=celldem)
    assert not temporary_decks(tmp_path)
    for bad, kind in (([1, 2], "list"), (42, "int"), (None, "NoneType"), (b"deck.json", "bytes")):
        with pytest.raises(TypeError, match=f"^deck: .*not {kind}$"):
            api.check_deck(bad, celldem=celldem)
        with pytest.raises(TypeError, match=f"^deck: .*not {kind}$"):
            api.run_deck(bad, tmp_path / "out", threads=1, celldem=celldem)
    assert not (tmp_path / "out").exists()
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(api.DeckError, match="bad.json: not JSON"):
        api.check_deck(tmp_path / "bad.json", celldem=celldem)
