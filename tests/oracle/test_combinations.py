"""Features that meet (combinations.py): probes on every kind of test, rate checks on extension, ramp and rotation
legs (and refused beside an adaptive rate), an interrupt under --tolerance and --seeds continued as printed, and
snapshots by e1 killed and resumed, each judged by its invariant against an uninterrupted or independent run.

CELLDEM_ORACLE_DRAWS (default 8, two trials of each kind) sets how many trials; CELLDEM_ORACLE_SEED (default 53) their
seed. A trial that did not set up what it tests (a kill before the test started or after the run ended) is skipped.
The longer run: `combinations.py --draws N --seed S --binary build/celldem`.
"""

import json
import os
import subprocess

import pytest

import combinations

SEED = int(os.environ.get("CELLDEM_ORACLE_SEED", "53"))
DRAWS = int(os.environ.get("CELLDEM_ORACLE_DRAWS", "8"))


@pytest.fixture(scope="session")
def context(celldem, tmp_path_factory):
    return combinations.context(celldem, str(tmp_path_factory.mktemp("combinations")))


@pytest.mark.parametrize("index", range(DRAWS))
def test_trial(context, index):
    kind, verdict, detail = combinations.run_trial(SEED, index, context)
    rerun = f"combinations.py --seed {SEED} --first {index} --draws 1 --verbose"
    assert verdict != "failed", f"trial {index} ({kind}; rerun: {rerun}):\n{detail}"
    if verdict == "skipped":
        pytest.skip(detail)


def test_snapshots_by_negative_e1(context):
    """An extension's snapshots by e1 (negative strains) are taken at the first step whose e1 reaches each strain
    (e1 <= it), not all at the start: the cell's box in each .dump gives its e1, 1 - L1 / L1(start)."""
    inc, targets = -1e-5, [-0.004, -0.0015]
    t = combinations.test_of(__import__("random").Random(1), "extension", steps=500)
    t.update(axes={"x1": {"strain_increment": inc}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
             end={"steps": 500}, snapshots={"e1": targets, "format": "ascii"})
    folder = os.path.join(context["folder"], "negative_e1")
    deck = combinations.write(folder + ".json", combinations.deck_with([t], context["state"]))
    r = subprocess.run([context["binary"], "run", deck, "--out", folder, "--force", "--quiet"], capture_output=True,
                       text=True, env=combinations.ENV)
    assert r.returncode == 0, r.stderr[-2000:]
    snaps = os.path.join(folder, "t", "snapshots")

    def box(step):
        with open(os.path.join(snaps, f"t_{step}.dump")) as f:
            lines = f.read().splitlines()
        return float(lines[lines.index("ITEM: BOX BOUNDS pp pp pp") + 1].split()[1])

    steps = sorted(int(n[2:-5]) for n in os.listdir(snaps) if n.endswith(".dump"))
    assert steps[0] == 0 and steps[-1] == 500, steps
    inner = steps[1:-1]
    assert len(inner) == len(targets), f"snapshots at steps {steps}, e1 targets {targets}"
    for step, target in zip(inner, sorted(targets, reverse=True)):
        e1 = 1 - box(step) / box(0)
        assert target - 2 * abs(inc) < e1 <= target, f"snapshot at step {step}: e1 {e1}, target {target}"
    with open(os.path.join(folder, "summary.json")) as f:
        assert json.load(f)["tests"]["t"]["steps"] == 500


def test_no_peak_reason_is_the_summarys_evidence(context):
    """A simple shear whose |s12|/s22 is largest before its last row but falls less than the 1 % a peak needs: the
    `peak` probe point is not run, and its reason gives that evidence (the console's), not "largest at the end"."""
    t = {"name": "t", "friction": 0.5, "output_interval": 100, "end": {"steps": 3000},
         "simple_shear": {"gamma_increment": 2e-5, "normal_stress": 1e5},
         "probes": {"at": ["peak"], "kind": "strain", "magnitudes": [1e-5], "steps": 50, "hold_steps": 30,
                    "rest_max_steps": 0}}
    folder = os.path.join(context["folder"], "no_peak_reason")
    deck = combinations.write(folder + ".json", combinations.deck_with([t], context["state"]))
    r = subprocess.run([context["binary"], "run", deck, "--out", folder, "--force"], capture_output=True, text=True,
                       env=combinations.ENV)
    assert r.returncode == 0, r.stderr[-2000:]
    rows = combinations.read_rows(os.path.join(folder, "t", "series.csv"))
    m = [abs(float(x["s12"])) / float(x["s22"]) for x in rows]
    with open(os.path.join(folder, "summary.json")) as f:
        s = json.load(f)["tests"]["t"]
    # The case this test needs (the deck and sample are fixed; a change of physics that loses it fails here).
    assert s["shear"]["peak_reached"] is False and m.index(max(m)) < len(rows) - 1, (s["shear"], m[-3:])
    reason = s["probes"]["points"]["peak"]["reason"]
    assert "largest at the end" not in reason, reason
    console = [line for line in r.stdout.splitlines() if line.startswith("t: no peak reached: ")]
    assert console and console[0][len("t: no peak reached: "):].split(" (its peak")[0] in reason, (console, reason)
