"""tools/compare_binaries.py OLD NEW --equivalence (tools/celldem/performance/equivalence.py): the verdict's rules on
synthetic folders (equivalent, a failed control, an untested quantity, identical differences); then the tool on a
100-sphere deck (TTC and PSC to ε1 = 4 %, about a second a seed): the build's binary against itself gives identical
bits, OLD's tests from its saved state are the bytes of its direct run, a NEW that changes only round-off (a
wrapper running the binary at a time step 1 + 1e-12 times the deck's) is not called different, a NEW with half the
friction is not equivalent; an interrupted study and a half-written run continue where they stopped; another
binary, deck or margin in the folder, a second process and bad options are refused."""

import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from celldem.commands import compare_binaries
from celldem.performance import equivalence
from checking import ROOT, TOOLS, tool

SEEDS = "3"


def tiny_deck(path, count=100):
    """tests/run/small_run.json with 100 spheres, a shorter preparation and TTC and PSC to ε1 = 4 %."""
    with open(os.path.join(ROOT, "tests", "run", "small_run.json")) as f:
        deck = json.load(f)
    deck["sample"]["count"] = count
    deck["prepare"].update(servo_max_strain_increment=1e-5, fast_solid_fraction=0.55)
    for test in deck["tests"]:
        test["end"]["strain"] = 0.04
        test["axes"]["x1"]["strain_increment"] = 1e-6
        test["output_interval"] = 200
    with open(path, "w") as f:
        json.dump(deck, f)
    return str(path)


def wrapper(path, real, change):
    """An executable NEW: the real binary, its `run` on a copy of the deck changed by `change` (Python acting on
    `deck`), written beside it."""
    path.write_text(f"""#!{sys.executable}
import json, os, sys
REAL = {real!r}
args = sys.argv[1:]
if args[:1] == ["run"]:
    with open(args[1]) as f:
        deck = json.load(f)
    {change}
    changed = os.path.join(os.path.dirname(os.path.abspath(args[1])), "changed-" + os.path.basename(args[1]))
    with open(changed, "w") as f:
        json.dump(deck, f)
    args[1] = changed
os.execv(REAL, [REAL] + args)
""")
    path.chmod(0o755)
    return str(path)


def equivalence_tool(old, new, deck, out, *options, check=False):
    return tool("compare_binaries", old, new, "--equivalence", "--deck", deck, "--out", out, *options, check=check)


def done_record(out, role, seed):
    """A run's done.json as text (its finish time and wall time): unchanged exactly when the run was not redone."""
    with open(os.path.join(equivalence.run_dir(out, role, seed), equivalence.DONE)) as f:
        return f.read()


def records(out, seeds):
    return {(role, s): done_record(out, role, s) for s in seeds for role in equivalence.ROLES
            if equivalence.complete(out, role, s)}


# ---- the verdict's rules on synthetic folders ---------------------------------------------------------------------

def write_summary(path, k, peak, ev, z, controlled=True, b_final=None):
    """Seed k's summary with one test; ε1 and b at the peak and b at the end exact binary fractions of k."""
    os.makedirs(path, exist_ok=True)
    test = {"controlled": controlled, "peak_reached": True, "peak_ratio13": peak, "e1_at_peak": 0.015625 * k,
            "b_at_peak": 0.0078125 * k, "end_window": {"ev": ev, "Z": z}, "steps": 1000, "wall_s": 1.0}
    if b_final is not None:  # None: left out
        test["b_final"] = b_final
    with open(os.path.join(path, "summary.json"), "w") as f:
        json.dump({"settings": {"particles": 100}, "tests": {"ttc": test}}, f)


def synthetic(out, shift=1e-4, alternate=True, **other):
    """Six seeds; OTHER = BASE + a shift of the peak (by default far inside the margin: a few 1e-4 floors, of
    alternating sign; alternate False: the same sign on every seed), the rest as `other` says."""
    values = [(3.0, -0.010, 4.1), (3.2, -0.012, 4.3), (2.9, -0.008, 4.0), (3.1, -0.011, 4.2), (3.05, -0.009, 4.15),
              (2.95, -0.0105, 4.05)]
    for k, (peak, ev, z) in enumerate(values, start=1):
        write_summary(equivalence.run_dir(out, "old", k), k, peak, ev, z, b_final=0.125 * k)
        jitter = shift * ((1 if k % 2 else -0.5) if alternate else (1 + 0.1 * (k % 2)))
        changes = {"b_final": 0.125 * k, **{key: (v(k) if callable(v) else v) for key, v in other.items()}}
        write_summary(equivalence.run_dir(out, "new", k), k, peak + jitter, ev + jitter * 1e-3, z, **changes)
    return list(range(1, 7))


def test_small_differences_are_equivalent_and_identical_values_say_so(tmp_path):
    seeds = synthetic(str(tmp_path))
    r = equivalence.judge(str(tmp_path), seeds)
    verdicts = {q["label"]: q["verdict"] for q in r["comparison"]["quantities"]}
    assert r["verdict"] == "equivalent" and r["exit"] == 0, r["text"]
    assert verdicts["ttc peak σ1/σ3"] == "equivalent"
    # Z, ε1 and b the same numbers in both: no TOST on zeros (celldem.stats would give p = 0 from no spread)
    assert verdicts["ttc Z at the end"] == "identical on every seed"
    assert r["not_compared"] == ["prepared e", "prepared Z"]  # not in the summaries of runs from a state
    assert "±0.5 floors on every quantity (TOST, 5 % per quantity)" in r["text"]


def test_a_failed_control_an_untested_quantity_or_a_constant_offset_is_never_equivalent(tmp_path):
    failed = str(tmp_path / "failed")
    seeds = synthetic(failed, controlled=lambda k: k != 3)
    r = equivalence.judge(failed, seeds)
    assert r["verdict"] == "not shown equivalent" and r["exit"] == 1
    assert r["control_failures"] == [{"seed": 3, "binary": "NEW", "test": "ttc", "failures": []}]
    assert "control failed: seed 3 NEW ttc" in r["text"]

    missing = str(tmp_path / "missing")
    seeds = synthetic(missing, b_final=lambda k: None)  # NEW's summaries lack a quantity OLD's have
    r = equivalence.judge(missing, seeds)
    assert r["exit"] == 1 and r["missing"] == ["ttc b at the end"], r["text"]
    assert "ttc b at the end: missing: no value from NEW on seeds 1, 2, 3, 4, 5, 6" in r["text"]

    offset = str(tmp_path / "offset")
    # the same small difference on every seed (exactly: binary fractions): no spread to test with
    seeds = synthetic(offset, b_final=lambda k: 0.125 * k + 2.0 ** -20)
    r = equivalence.judge(offset, seeds)
    row = next(q for q in r["comparison"]["quantities"] if q["label"] == "ttc b at the end")
    assert row["verdict"].startswith("undecided at 6 seeds") and r["exit"] == 1


def edit_summary(out, role, seed, change):
    path = os.path.join(equivalence.run_dir(out, role, seed), "summary.json")
    with open(path) as f:
        summary = json.load(f)
    change(summary["tests"]["ttc"])
    with open(path, "w") as f:
        json.dump(summary, f)  # (NaN as NaN, as Python's json writes it)


def test_a_nan_or_a_missing_peak_on_one_side_is_never_left_out_silently(tmp_path):
    # a NaN from NEW where OLD has a number: named, not dropped from the pairs
    nan = str(tmp_path / "nan")
    seeds = synthetic(nan)
    edit_summary(nan, "new", 2, lambda t: t["end_window"].update(Z=float("nan")))
    r = equivalence.judge(nan, seeds)
    assert r["exit"] == 1 and r["missing"] == ["ttc Z at the end"], r["text"]
    assert "no value from NEW on seeds 2" in r["text"]

    # NEW reaches no peak on two seeds where OLD did: the peak-reached row sees it (OLD always reached one, so it
    # has no floor to judge against: untested, never equivalent); the peak quantities are paired on 4 seeds
    peak = str(tmp_path / "peak")
    seeds = synthetic(peak)
    for k in (2, 5):
        edit_summary(peak, "new", k, lambda t: t.update(peak_reached=False))
    r = equivalence.judge(peak, seeds)
    rows = {q["label"]: q for q in r["comparison"]["quantities"]}
    assert rows["ttc peak reached (1/0)"]["verdict"].startswith("untested (no floor"), r["text"]
    assert rows["ttc peak reached (1/0)"]["differences"] == [0, -1, 0, 0, -1, 0]
    assert rows["ttc peak σ1/σ3"]["n"] == 4 and r["exit"] == 1

    # a quantity paired on fewer than 3 seeds is not judged
    few = str(tmp_path / "few")
    seeds = synthetic(few)
    for k in (1, 2, 3, 4):
        edit_summary(few, "old", k, lambda t: t.update(peak_reached=False))
    r = equivalence.judge(few, seeds)
    rows = {q["label"]: q for q in r["comparison"]["quantities"]}
    assert rows["ttc peak σ1/σ3"]["verdict"] == "untested (paired on 2 seeds, fewer than 3)", r["text"]
    assert "ttc peak σ1/σ3" in r["untested"] and r["exit"] == 1


def test_a_shift_of_a_floor_is_not_equivalent_and_a_steady_shift_is_different(tmp_path):
    seeds = synthetic(str(tmp_path / "scattered"), shift=0.5)  # 0.5 and -0.25 by turns: 1.2 floors on the mean
    r = equivalence.judge(str(tmp_path / "scattered"), seeds)
    assert r["exit"] == 1 and r["undecided"] == ["ttc peak σ1/σ3"], r["text"]
    seeds = synthetic(str(tmp_path / "steady"), shift=0.3, alternate=False)  # about 3 floors on every seed
    r = equivalence.judge(str(tmp_path / "steady"), seeds)
    assert r["exit"] == 1 and r["different"] == ["ttc peak σ1/σ3"], r["text"]
    assert "different: ttc peak σ1/σ3" in r["text"]


# ---- the tool on a tiny deck ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def deck(tmp_path_factory):
    return tiny_deck(tmp_path_factory.mktemp("deck") / "tiny.json")


@pytest.fixture(scope="module")
def same(tmp_path_factory, celldem, deck):
    """The build's binary against itself on seeds 1-3: (out, verdict, the completed process)."""
    root = tmp_path_factory.mktemp("same")
    out = str(root / "study")
    r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS, "--json", root / "verdict.json")
    return out, json.loads((root / "verdict.json").read_text()), r


def test_a_binary_against_itself_gives_identical_bits(same, celldem):
    out, verdict, r = same
    assert r.returncode == 0, r.stderr
    assert verdict["verdict"] == "identical bits" and verdict["comparison"] is None
    assert "identical bits" in r.stdout and verdict["seeds"] == [1, 2, 3]
    for k in (1, 2, 3):
        for folder, result in (("samples", "prepared.state"), ("base", "summary.json"), ("other", "summary.json")):
            assert os.path.isfile(os.path.join(out, folder, f"seed-{k}", result))
    recorded = json.load(open(os.path.join(out, "equivalence.json")))
    assert recorded["old"]["sha256"] == equivalence.sha256_of(celldem) and recorded["margin_floors"] == 0.5
    assert "3 of 3" in r.stderr and "ETA" in r.stderr  # progress on stderr
    assert os.path.isfile(os.path.join(out, "equivalence.md"))


def test_old_tests_from_the_saved_state_are_the_bytes_of_its_direct_run(same, celldem, deck, tmp_path):
    out, _, _ = same
    with open(deck) as f:
        d = json.load(f)
    d["sample"]["seed"] = 2
    direct_deck = tmp_path / "direct.json"
    direct_deck.write_text(json.dumps(d))
    subprocess.run([celldem, "run", direct_deck, "--out", tmp_path / "direct", "--threads", "1", "--quiet"],
                   check=True, capture_output=True)
    from_state = equivalence.run_dir(out, "old", 2)
    for test in ("ttc", "psc"):
        assert sorted(os.listdir(tmp_path / "direct" / test)) == sorted(os.listdir(os.path.join(from_state, test)))
        for name in sorted(os.listdir(tmp_path / "direct" / test)):
            direct = (tmp_path / "direct" / test / name).read_bytes()
            with open(os.path.join(from_state, test, name), "rb") as f:
                assert f.read() == direct, f"{test}/{name}"
    summaries = [json.load(open(os.path.join(p, "summary.json"))) for p in (tmp_path / "direct", from_state)]
    tests = [equivalence._without_run_time({"tests": s["tests"]}) for s in summaries]
    assert tests[0] == tests[1]


def test_a_second_call_runs_nothing_again(same, celldem, deck):
    out, _, _ = same
    before = records(out, (1, 2, 3))
    r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS)
    assert r.returncode == 0 and "identical bits" in r.stdout and "all 3 seeds complete" in r.stderr
    assert records(out, (1, 2, 3)) == before


def test_a_round_off_change_is_not_called_different(tmp_path, celldem, deck):
    new = wrapper(tmp_path / "roundoff", celldem, 'deck["time_step"] *= 1 + 1e-12')
    out = str(tmp_path / "study")
    r = equivalence_tool(celldem, new, deck, out, "--seeds", "4", "--json", tmp_path / "v.json")
    assert r.returncode in (0, 1), r.stderr
    v = json.loads((tmp_path / "v.json").read_text())
    assert v["verdict"] != "identical bits" and all(v["differing_outputs"][str(k)] for k in (1, 2, 3, 4))
    # The runs are chaotic: the change sends each down another path, and the summaries differ. What is guaranteed
    # is that a difference this small is not called "different" but by chance (Holm: 5 % for the family); with 4
    # seeds most quantities are undecided or equivalent.
    assert v["different"] == [], v["text"]
    assert (r.returncode == 0) == (v["verdict"] == "equivalent")
    assert "| quantity |" in r.stdout and "Verdict" in r.stdout


def test_half_the_friction_is_not_equivalent(tmp_path, celldem, deck):
    new = wrapper(tmp_path / "friction", celldem, 'for t in deck["tests"]: t["friction"] *= 0.5')
    out = str(tmp_path / "study")
    r = equivalence_tool(celldem, new, deck, out, "--seeds", "4", "--json", tmp_path / "v.json")
    v = json.loads((tmp_path / "v.json").read_text())
    assert r.returncode == 1 and v["verdict"] == "not shown equivalent", v["text"]
    largest = max(abs(q["floors"]) for q in v["comparison"]["quantities"] if q["floors"] is not None)
    assert largest > 2, v["text"]  # half the friction moves the peak and Z by several floors
    assert "not shown equivalent" in r.stdout


def test_an_interrupted_study_and_a_half_written_run_continue_where_they_stopped(tmp_path, celldem, deck):
    out = str(tmp_path / "study")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([TOOLS] + ([os.environ["PYTHONPATH"]]
                                                                   if os.environ.get("PYTHONPATH") else [])))
    proc = subprocess.Popen([sys.executable, os.path.join(TOOLS, "compare_binaries.py"), celldem, celldem,
                             "--equivalence", "--deck", deck, "--out", out, "--seeds", "3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if "done, 1 of 3" in line:
            proc.send_signal(signal.SIGINT)
            break
    seen.append(proc.communicate(timeout=120)[1])
    assert proc.returncode == 130, "".join(seen)
    complete = [k for k in (1, 2, 3) if equivalence.seed_complete(out, k)]
    assert 1 <= len(complete) < 3
    first = complete[0]
    # a half-written run: NEW's tests of a complete seed lose their done.json
    redo = done_record(out, "new", first)
    os.remove(os.path.join(equivalence.run_dir(out, "new", first), equivalence.DONE))
    kept = records(out, (1, 2, 3))
    r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS)
    assert r.returncode == 0 and "identical bits" in r.stdout, r.stderr
    after = records(out, (1, 2, 3))
    assert len(after) == 9
    assert all(after[key] == text for key, text in kept.items()), "a complete run was run again"
    assert after[("new", first)] != redo  # run again
    assert f"{len(complete) - 1} of 3 seeds complete" in r.stderr


def children_in(out):
    """The processes whose working folder lies in OUT (the study's celldem runs)."""
    found = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            if os.readlink(f"/proc/{pid}/cwd").startswith(out + os.sep):
                found.append(int(pid))
        except OSError:
            pass
    return found


def running_in(out, program):
    """Whether a process whose working folder lies in OUT runs `program` (its command line names it)."""
    for pid in children_in(out):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if program.encode() in f.read():
                    return True
        except OSError:
            pass
    return False


def start_study(old, new, deck, out, program="celldem"):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([TOOLS] + ([os.environ["PYTHONPATH"]]
                                                                   if os.environ.get("PYTHONPATH") else [])))
    proc = subprocess.Popen([sys.executable, os.path.join(TOOLS, "compare_binaries.py"), old, new,
                             "--equivalence", "--deck", deck, "--out", out, "--seeds", "3"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    for line in proc.stderr:
        if "OLD prepares the sample" in line:
            break
    deadline = time.monotonic() + 30
    while not running_in(out, program) and time.monotonic() < deadline:
        time.sleep(0.01)
    assert running_in(out, program), "no run started"
    return proc


def test_a_killed_study_takes_its_runs_with_it_and_continues(tmp_path, celldem, deck):
    # An OLD whose runs would last a minute (it checks decks as celldem does): killed by SIGKILL, the study leaves
    # no run behind to write into a folder the next call starts again.
    slow = wrapper(tmp_path / "slow", celldem, 'os.execv("/bin/sleep", ["sleep", "60"])')
    out = str(tmp_path / "slow-study")
    proc = start_study(slow, celldem, deck, out, program="sleep")
    proc.kill()  # SIGKILL: no handler of the study runs
    proc.wait()
    deadline = time.monotonic() + 5
    while children_in(out) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not children_in(out), "a run outlived the killed study"
    # The real binary, killed and at once called again: it continues and completes.
    out = str(tmp_path / "study")
    proc = start_study(celldem, celldem, deck, out)
    proc.kill()
    proc.wait()
    r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS)
    assert r.returncode == 0 and "identical bits" in r.stdout, r.stderr


def test_a_new_that_writes_nothing_is_a_failed_run(tmp_path, celldem, deck):
    silent = tmp_path / "silent"
    silent.write_text("#!/bin/sh\nexit 0\n")
    silent.chmod(0o755)
    r = equivalence_tool(celldem, str(silent), deck, str(tmp_path / "study"), "--seeds", SEEDS)
    assert r.returncode == 2 and "NEW's tests exited 0 but wrote no summary.json" in r.stderr, r.stderr


def test_other_binaries_a_deck_or_a_margin_in_the_folder_are_refused_unless_forced(same, celldem, deck, tmp_path):
    out = str(tmp_path / "copy")
    shutil.copytree(same[0], out)
    before = records(out, (1, 2, 3))
    new = wrapper(tmp_path / "other", celldem, "pass")
    other_deck = tiny_deck(tmp_path / "other.json", count=120)
    for args, message in (((celldem, new, deck), "the new binary"), ((celldem, celldem, other_deck), "the deck"),
                          ((celldem, celldem, deck, "--margin", "0.6"), "the margin")):
        r = equivalence_tool(*args[:3], out, "--seeds", SEEDS, *args[3:])
        assert r.returncode == 2 and message in r.stderr and "--force" in r.stderr, (args, r.stderr)
    assert records(out, (1, 2, 3)) == before  # nothing written was touched
    r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS, "--margin", "0.6", "--force")
    assert r.returncode == 0, r.stderr
    after = records(out, (1, 2, 3))
    assert all(after[key] != text for key, text in before.items())  # everything run again
    assert json.load(open(os.path.join(out, "equivalence.json")))["margin_floors"] == 0.6


def test_a_second_process_on_the_folder_is_refused(same, celldem, deck):
    out = same[0]
    with open(os.path.join(out, equivalence.LOCK), "a+") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        r = equivalence_tool(celldem, celldem, deck, out, "--seeds", SEEDS)
    assert r.returncode == 2 and "in use by another process" in r.stderr, r.stderr


def test_bad_options_are_refused(tmp_path, celldem, deck, capsys):
    plain = tmp_path / "plain"
    plain.write_text("not a binary")
    started = tiny_deck(tmp_path / "started.json")
    with open(started) as f:
        d = json.load(f)
    d["initial_state"] = "prepared.state"
    with open(started, "w") as f:
        json.dump(d, f)
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("someone else's")
    out = str(tmp_path / "out")
    cases = [
        ([str(tmp_path / "missing"), celldem, "--deck", deck], "no executable old binary"),
        ([celldem, str(plain), "--deck", deck], "no executable new binary"),
        ([celldem, celldem, "--deck", deck, "--seeds", "2"], "--seeds must give at least 3"),
        ([celldem, celldem, "--deck", deck, "--seeds", "4-2"], "--seeds"),
        ([celldem, celldem, "--deck", deck, "--seeds", "x"], "--seeds"),
        ([celldem, celldem, "--deck", deck, "--margin", "0"], "--margin must be a positive"),
        ([celldem, celldem, "--deck", deck, "--margin", "-1"], "--margin must be a positive"),
        ([celldem, celldem, "--deck", deck, "--jobs", "0"], "--jobs must be from 1 to the"),
        ([celldem, celldem, "--deck", deck, "--jobs", "100000"], "--jobs must be from 1 to the"),
        ([celldem, celldem, "--deck", deck, "--seeds", "99999999999999999999"], "asks for more than 1000 seeds"),
        ([celldem, celldem, "--deck", deck, "--seeds", "5000"], "asks for more than 1000 seeds"),
        ([celldem, celldem, "--deck", deck, "--json", str(tmp_path / "no" / "v.json")], "--json: cannot write"),
        ([celldem, celldem, "--deck", str(tmp_path / "none.json")], "--deck: no deck at"),
        ([celldem, celldem, "--deck", str(plain)], "is not a JSON deck"),
        ([celldem, celldem, "--deck", started], "--deck:"),
        ([celldem, celldem, "--deck", deck, "--rounds", "3"], "--rounds does not apply with --equivalence"),
        ([celldem, celldem, "--deck", deck, "--out", str(foreign)], "not an equivalence folder"),
    ]
    for args, message in cases:
        argv = args[:2] + ["--equivalence"] + args[2:] + ([] if "--out" in args else ["--out", out])
        assert compare_binaries.main(argv) == 2, args
        err = capsys.readouterr().err
        assert message in err, (args, err)
    assert not os.path.exists(out)  # nothing written on bad input
    assert compare_binaries.main([celldem, celldem, "--seeds", "3"]) == 2  # an --equivalence option without it
    assert "--seeds does not apply without --equivalence" in capsys.readouterr().err
    assert os.listdir(foreign) == ["notes.txt"]
