#!/usr/bin/python3
"""Seeded random trials of features that meet, each judged by an invariant between them.

Four kinds of trial, drawn in turn (trial i of seed S is `KINDS[i % 4]` with the random stream seeded (S, i)):

- `probes`: probes (`at: peak`, sometimes `end`; strain or stress probes, probed without rest) on a simple shear,
  an extension, a principal-axis rotation, a stress ramp or a compression. The run either refuses with exit 2 naming
  `probes`, or exits 0 and then: the `peak` point's step is the first row of the largest driven measure (the measure
  summary.json's `driven_measure` names: s11/s33, s33/s11, |s12|/s22; a rotation or a ramp follows s11/s33); the
  summary's at-peak strain (`shear.g_at_peak`, `extension.e1_at_peak`, `e1_at_peak`) is that row's; `peak_state`'s
  principal stresses are that row's stress tensor's eigenvalues; a shear or extension test's top-level
  `peak_ratio13` is null; a point that ran starts its probes from that row (each probe's first row holds its strains
  and stresses).
  The result oracle (oracle.py) agrees with the summary.
- `rate`: a rate check (`verify_rate`, no twin) on an extension, a stress ramp, a rotation, a three-leg test
  (compression, ramp, rotation), or beside an adaptive rate (then exit 2 naming `adaptive_rate` is required). Per
  leg, the slower run's mean driven rate over the test's (strain, stress or principal angle changed over the leg's
  time) is `rate_factor`, within the controls' error; the compared peak is the driven measure's.
- `continue`: `--tolerance T --seeds a-b` stopped by SIGINT at a random moment; the printed "Continue with" command,
  run as printed, exits 0, and the run's series are the bytes of an uninterrupted run's, its summaries and
  ensemble.json the same values (timings aside).
- `resume`: snapshots by e1 and checkpoints, killed (SIGINT or SIGKILL) at a random moment inside the test and
  resumed (the printed command after SIGINT, `--resume` after SIGKILL): series, snapshots and summary as above.

A trial that did not set up what it tests (the kill landed before the test started or after the run ended) is
skipped, never passed. Usage:

    /usr/bin/python3 tests/oracle/combinations.py --draws 40 --seed 1 --binary build/celldem [--out DIR] [--verbose]
                     [--kinds resume ...]

`--first i --draws 1` reruns trial i alone; `--kinds` runs only the trials of those kinds among the range (the others
are not run, and each trial keeps its index and stream); each failure prints its deck and command.
"""

import argparse
import csv
import glob
import json
import math
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oracle  # noqa: E402

P0 = 1e5
KINDS = ("probes", "rate", "continue", "resume")
ENV = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE")
SAMPLE = {"count": 150, "diameters": {"min": 0.003, "max": 0.0045, "count": 4}, "density": 2650, "seed": 11,
          "grid_spacing": 0.005}
BASE = {"format": 1, "sample": SAMPLE, "contact": {"kn": 1e6, "kt": 1e6},
        "damping": {"translational": 0.05, "rotational": 0.05}, "time_step": 1e-6, "control_failure": "warn"}
PREPARE = {"target_pressure": P0, "fast_strain_increment": 5e-5, "output_interval": 500,
           "equilibrium": {"min_steps": 2000, "max_steps": 200000, "unbalanced_force_ratio": 0.02,
                           "check_interval": 500}}
SERVO_TOLERANCE = 0.005  # solver/run/health.hpp kServoTolerance
STRESS_COLUMNS = ("e1", "e2", "e3", "ev", "s11", "s22", "s33", "s12", "s13", "s23")
TIMING = re.compile(r"wall|per_s$|elapsed|estimated_s|_seconds$")


def deck_with(tests, state=None, **top):
    d = json.loads(json.dumps(BASE))
    if state:
        d["initial_state"] = state
    else:
        d["prepare"] = json.loads(json.dumps(PREPARE))
    d["tests"] = tests
    d.update(top)
    return d


def prepare_sample(binary, folder):
    state = os.path.join(folder, "sample", "prepared.state")
    if not os.path.exists(state):
        os.makedirs(folder, exist_ok=True)
        path = write(os.path.join(folder, "sample.json"), deck_with([]))
        r = subprocess.run([binary, "run", path, "--out", os.path.join(folder, "sample"), "--force", "--quiet"],
                           capture_output=True, text=True, env=ENV)
        if r.returncode:
            raise RuntimeError(f"the sample's preparation failed ({r.returncode}): {r.stderr[-2000:]}")
    return state


def write(path, deck):
    with open(path, "w") as f:
        json.dump(deck, f, indent=1)
    return path


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def fl(row, key):
    return float(row[key])


# ----------------------------------------------------------------------------------------------- the tests drawn
def test_of(rng, kind, name="t", steps=None):
    """One test of a kind: shear, extension, rotation, ramp, axial; its leg dict merged into the test."""
    steps = steps or rng.choice([1500, 2000, 3000])
    t = {"name": name, "friction": rng.choice([0.3, 0.5]), "output_interval": rng.choice([50, 100])}
    if kind == "shear":
        t["simple_shear"] = {"gamma_increment": rng.choice([1e-5, 2e-5]), "normal_stress": P0}
        t["end"] = {"steps": steps}
    elif kind in ("extension", "axial"):
        inc = rng.choice([5e-6, 1e-5]) * (-1 if kind == "extension" else 1)
        t["axes"] = {"x1": {"strain_increment": inc}, "x2": {"stress": P0}, "x3": {"stress": P0}}
        t["end"] = rng.choice([{"steps": steps}, {"axis": "x1", "strain": round(inc * steps, 9)}])
    elif kind == "rotation":
        plane = rng.choice(["x1x2", "x1x3", "x2x3"])
        other = {"x1x2": "x3", "x1x3": "x2", "x2x3": "x1"}[plane]
        t["axes"] = {other: {"stress": P0}}
        t["rotate_principal_axes"] = {"plane": plane, "sigma1": rng.choice([1.2e5, 1.4e5]), "sigma3": P0,
                                      "rate": rng.choice([1e4, 2e4]) * rng.choice([1, -1])}
        t["end"] = {"steps": steps}
    elif kind == "ramp":
        rate = rng.choice([1e7, 2e7])
        t["axes"] = {"x1": {"stress_ramp": {"from": P0, "rate": rate}}, "x2": {"stress": P0}, "x3": {"stress": P0}}
        t["end"] = rng.choice([{"steps": steps}, {"axis": "x1", "stress": P0 + 0.8 * rate * steps * 1e-6,
                                                  "max_steps": 2 * steps}])
    else:
        raise ValueError(kind)
    return t


def measure_of(summary_test, test, rows):
    """The driven measure named by summary.json, per row."""
    name = summary_test.get("driven_measure", "")
    m = re.fullmatch(r"(\|?)(s\d\d)\|?/(s\d\d)", name)
    if m:
        absolute, a, b = m.groups()
        return name, [(abs(fl(r, a)) if absolute else fl(r, a)) / fl(r, b) for r in rows]
    return "s11/s33", [fl(r, "ratio13") for r in rows]  # a rotation or a stress-controlled test follows s11/s33


def tensor(row):
    return np.array([[fl(row, "s11"), fl(row, "s12"), fl(row, "s13")], [fl(row, "s12"), fl(row, "s22"), fl(row, "s23")],
                     [fl(row, "s13"), fl(row, "s23"), fl(row, "s33")]])


def close(a, b, rel=1e-8, floor=1e-12):
    return abs(a - b) <= rel * max(abs(a), abs(b)) + floor


def run(binary, args, cwd=None, timeout=600):
    return subprocess.run([binary, "run", *args], capture_output=True, text=True, env=ENV, cwd=cwd, timeout=timeout)


def refused_naming(r, *keys):
    return r.returncode == 2 and any(k in r.stderr for k in keys)


# ------------------------------------------------------------------------------------------------------ probes
def trial_probes(rng, ctx, tag):
    kind = rng.choice(["shear", "extension", "rotation", "ramp", "axial"])
    t = test_of(rng, kind)
    probes = {"at": ["peak"] + (["end"] if rng.random() < 0.3 else []), "steps": rng.choice([50, 100]),
              "hold_steps": 30, "rest_max_steps": 0}
    if rng.random() < 0.5:
        probes.update(kind="strain", magnitudes=[1e-5])
    else:
        probes.update(kind="stress", plane="rendulic", directions=2, magnitudes=[2000])
    t["probes"] = probes
    deck = write(os.path.join(ctx["folder"], f"{tag}.json"), deck_with([t], ctx["state"]))
    out = os.path.join(ctx["folder"], tag)
    r = run(ctx["binary"], [deck, "--out", out, "--force", "--quiet"])
    what = f"{kind} with {probes['kind']} probes; `celldem run {deck} --out {out}`"
    if refused_naming(r, "probes"):
        return "passed", f"{what}: refused (exit 2 naming probes)"
    if r.returncode:
        return "failed", f"{what}: exit {r.returncode}: {r.stderr[-800:]}"
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)["tests"]["t"]
    rows = read_rows(os.path.join(out, "t", "series.csv"))
    bad = oracle.check_run(out)
    name, m = measure_of(s, t, rows)
    top = max(range(len(rows)), key=lambda i: (m[i], -i))
    row = rows[top]
    point = s.get("probes", {}).get("points", {}).get("peak")
    if point is None:
        return "failed", f"{what}: no probes.points.peak in summary.json"
    if fl(row, "step") != point["step"]:
        at = [i for i, x in enumerate(rows) if fl(x, "step") == point["step"]]
        bad.append(f"the peak point is step {point['step']:.0f}, the largest {name} is at step {row['step']} "
                   f"({m[top]:.6g}; the point's row has {m[at[0]] if at else 'no row'})")
    at_peak = ((s.get("shear") or {}).get("g_at_peak"), "g12") if kind == "shear" else \
        ((s.get("extension") or {}).get("e1_at_peak"), "e1") if kind == "extension" else (s.get("e1_at_peak"), "e1")
    if at_peak[0] is None or not close(at_peak[0], fl(row, at_peak[1]), 1e-9, 1e-12):
        bad.append(f"summary's {at_peak[1]} at the peak {at_peak[0]}, the peak row's {row[at_peak[1]]}")
    ps = s.get("peak_state") or {}
    eig = sorted(np.linalg.eigvalsh(tensor(row)), reverse=True)
    for key, v in zip(("sigma1", "sigma2", "sigma3"), eig):
        if key not in ps or not close(ps[key], v, 1e-7, 1e-3):
            bad.append(f"peak_state.{key} {ps.get(key)}, the peak row's {v:.10g}")
    reason = point.get("reason", "")
    if point.get("status") == "not run" and reason.startswith("no peak reached"):
        last = top == len(rows) - 1
        if not last and re.search(r"largest (\([^)]*\) )?at the (end|last row)", reason):
            bad.append(f"the peak point's reason {reason!r}, but the largest {name} is at step {row['step']}, not the "
                       f"last row {rows[-1]['step']}")
        if name not in reason and s.get("driven_measure", "") not in reason:
            bad.append(f"the peak point's reason {reason!r} does not name the measure {name}")
    if kind in ("shear", "extension") and s.get("peak_ratio13") is not None:
        bad.append(f"a {kind} test's top-level peak_ratio13 is {s['peak_ratio13']}, not null")
    if point.get("status") not in ("not run", None):
        folder = os.path.join(out, point["folder"])
        firsts = [os.path.join(folder, p, "series.csv") for p in sorted(os.listdir(folder))
                  if os.path.exists(os.path.join(folder, p, "series.csv"))]
        if not firsts:
            bad.append(f"the peak point ran ({point['status']}) but {folder} has no probe series")
        for path in firsts:
            first = read_rows(path)[0]
            diff = [c for c in STRESS_COLUMNS if first[c] != row[c]]
            if diff:
                bad.append(f"{os.path.relpath(path, out)} starts at {', '.join(f'{c} {first[c]}' for c in diff[:3])}, "
                           f"the peak row has {', '.join(row[c] for c in diff[:3])}")
                break
    return ("failed", f"{what}: " + "; ".join(bad)) if bad else ("passed", f"{what}: peak step {row['step']}")


# --------------------------------------------------------------------------------------------------------- rate
def principal_angle(row, plane):
    i, j = int(plane[1]), int(plane[3])
    sij = fl(row, f"s{min(i, j)}{max(i, j)}")
    return 0.5 * math.degrees(math.atan2(2 * sij, fl(row, f"s{i}{i}") - fl(row, f"s{j}{j}")))


def leg_spans(rows):
    """Per leg: (start row, end row), the start being the previous leg's last row (the test's first for leg 0)."""
    out, prev = [], rows[0]
    legs = sorted({int(fl(r, "leg")) for r in rows})
    for k in legs:
        mine = [r for r in rows if int(fl(r, "leg")) == k]
        out.append((prev, mine[-1], mine))
        prev = mine[-1]
    return out


def leg_rate(leg, start, end, mine):
    """The leg's mean driven rate and its uncertainty (absolute). A strain: its change from the leg's start row to its
    end row over the leg's time (exact to the rows' 10 digits). A stress ramp or a rotation (whose target starts at
    its `from`, not where the last leg left the stress): the least-squares slope of the stress or the principal angle
    over the leg's second half, within its largest residual at either end (and 0.5 %)."""
    T = fl(end, "time") - fl(start, "time")
    if T <= 0:
        return math.nan, math.nan
    for ax, a in (leg.get("axes") or {}).items():
        if "strain_increment" in a and a["strain_increment"] != 0:
            col = "e" + ax[1:]
            return (fl(end, col) - fl(start, col)) / T, 2e-9 / T
    half = [r for r in mine if fl(r, "time") >= fl(start, "time") + T / 2]
    t = np.array([fl(r, "time") for r in half])
    if "rotate_principal_axes" in leg:
        plane = leg["rotate_principal_axes"]["plane"]
        q = np.degrees(np.unwrap(np.radians([2 * principal_angle(r, plane) for r in half])) / 2)
    else:
        ax = next(ax for ax, a in leg["axes"].items() if "stress_ramp" in a)
        q = np.array([fl(r, "s" + ax[1] * 2) for r in half])
    if len(t) < 3:
        return math.nan, math.nan
    slope, icept = np.polyfit(t, q, 1)
    # Within its residuals, and at least 0.5 %: a control's lag tilts a fitted slope by a fraction of a percent (a
    # rotation at 2e4 deg/s measured at 2.0025e4), far below what a wrong factor would (0.4 against 0.5 is 25 %).
    return slope, max(2 * np.max(np.abs(q - (slope * t + icept))) / (t[-1] - t[0]), 0.005 * abs(slope))


def trial_rate(rng, ctx, tag):
    kind = rng.choices(["extension", "ramp", "rotation", "legs", "adaptive"], [3, 3, 3, 3, 1])[0]
    factor = rng.choice([0.4, 0.5, 0.7])
    if kind == "legs":
        legs = [test_of(rng, k, steps=1200) for k in ("axial", "ramp", "rotation")]
        t = {"name": "t", "friction": 0.5, "output_interval": 50,
             "legs": [{k: v for k, v in leg.items() if k not in ("name", "friction", "output_interval")}
                      for leg in legs]}
        for leg in t["legs"]:
            leg["end"] = {"steps": 1200}
    elif kind == "adaptive":
        t = test_of(rng, "axial")
        t["end"] = {"axis": "x1", "strain": 0.01}
        t["adaptive_rate"] = {"max_factor": 4}
    else:
        t = test_of(rng, kind, steps=rng.choice([1000, 1500]))
    t["verify_rate"] = {"rate_factor": factor, "twin": False}
    deck = write(os.path.join(ctx["folder"], f"{tag}.json"), deck_with([t], ctx["state"]))
    out = os.path.join(ctx["folder"], tag)
    r = run(ctx["binary"], [deck, "--out", out, "--force", "--quiet"])
    what = f"rate check x{factor} on {kind}; `celldem run {deck} --out {out}`"
    if kind == "adaptive":
        return ("passed", f"{what}: refused") if refused_naming(r, "adaptive_rate") else \
            ("failed", f"{what}: expected exit 2 naming adaptive_rate, got exit {r.returncode}: {r.stderr[-600:]}")
    if r.returncode:
        return "failed", f"{what}: exit {r.returncode}: {r.stderr[-800:]}"
    with open(os.path.join(out, "summary.json")) as f:
        s = json.load(f)["tests"]["t"]
    rows = read_rows(os.path.join(out, "t", "series.csv"))
    slow = read_rows(os.path.join(out, "t", "verify", "rung-1", "series.csv"))  # (rate_factor f: rungs f and f²)
    legs = t.get("legs") or [t]
    a, b = leg_spans(rows), leg_spans(slow)
    bad = oracle.check_run(out)
    if len(a) != len(legs) or len(b) != len(legs):
        return "failed", f"{what}: legs in the series: test {len(a)}, slower run {len(b)}, deck {len(legs)}"
    runs = (s.get("verify_rate") or {}).get("runs", {})
    held = s.get("controlled") is True and (runs.get("rung-1") or {}).get("controlled") is True
    checked = 0
    for k, leg in enumerate(legs):
        strain = any("strain_increment" in x and x["strain_increment"] for x in (leg.get("axes") or {}).values())
        if not strain and not held:  # a stress's or an angle's rate is measured only where its control held
            continue
        checked += 1
        rt, ut = leg_rate(leg, *a[k])
        rs, us = leg_rate(leg, *b[k])
        if not (math.isfinite(rt) and math.isfinite(rs)):
            bad.append(f"leg {k}: no driven rate ({rt}, {rs})")
            continue
        ratio = rs / rt
        tol = (us + factor * ut) / abs(rt) + 1e-6
        if abs(ratio - factor) > tol:
            bad.append(f"leg {k}: the slower run's mean driven rate is {ratio:.5g} of the test's, not {factor} "
                       f"(test {rt:.6g}/s, slower {rs:.6g}/s, allowed {tol:.2g})")
    comp = (s.get("verify_rate") or {}).get("comparisons", {}).get("peak_ratio13", {})
    _, m = measure_of(s, legs[0] if kind != "legs" else t["legs"][2], rows)
    if kind in ("extension", "ramp") and comp.get("test") is not None and not close(comp["test"], max(m), 1e-7):
        bad.append(f"verify_rate.comparisons.peak_ratio13.test {comp['test']}, the test's largest "
                   f"{s.get('driven_measure')} {max(m):.10g}")
    first_rung = (comp.get("rungs") or [None])[0]
    if kind in ("extension", "ramp") and first_rung is not None:
        _, ms = measure_of(s, legs[0], slow)
        if not close(first_rung, max(ms), 1e-7):
            bad.append(f"verify_rate.comparisons.peak_ratio13.rungs[0] {first_rung}, the slower run's largest "
                       f"{s.get('driven_measure')} {max(ms):.10g}")
    if bad:
        return "failed", f"{what}: " + "; ".join(bad)
    if not checked:
        return "skipped", f"{what}: uncontrolled (test {s.get('controlled')}, slower run " \
                          f"{(runs.get('rung-1') or {}).get('controlled')}): no driven rate measured"
    return "passed", f"{what}: {checked} of {len(legs)} leg(s)"


# ------------------------------------------------------------------------------------- interrupts and resumes
def strip_timings(x):
    if isinstance(x, dict):
        return {k: strip_timings(v) for k, v in x.items() if not TIMING.search(k)}
    if isinstance(x, list):
        return [strip_timings(v) for v in x]
    return x


def differences(ref, out):
    """Files of the uninterrupted run that the resumed one lacks or differs in: series and snapshots by bytes,
    summary.json and ensemble.json by value (timings aside)."""
    bad = []
    for root, _, files in os.walk(ref):
        for name in files:
            path = os.path.join(root, name)
            rel = os.path.relpath(path, ref)
            other = os.path.join(out, rel)
            if name in ("summary.json", "ensemble.json"):
                if not os.path.exists(other):
                    bad.append(f"{rel} missing")
                    continue
                with open(path) as f, open(other) as g:
                    a, b = strip_timings(json.load(f)), strip_timings(json.load(g))
                if a != b:
                    bad.append(f"{rel} differs: {first_difference(a, b)}")
            elif name == "series.csv" or "/snapshots/" in "/" + rel:
                if not os.path.exists(other):
                    bad.append(f"{rel} missing")
                    continue
                with open(path, "rb") as f, open(other, "rb") as g:
                    if f.read() != g.read():
                        bad.append(f"{rel} differs in its bytes")
    return bad


def first_difference(a, b, path=""):
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b)):
            if a.get(k, "<none>") != b.get(k, "<none>"):
                return first_difference(a.get(k, "<none>"), b.get(k, "<none>"), f"{path}.{k}")
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            if x != y:
                return first_difference(x, y, f"{path}[{i}]")
    return f"{path or '.'}: {json.dumps(a)[:120]} against {json.dumps(b)[:120]}"


def reference(ctx, deck, args, cwd):
    """The uninterrupted run of a deck and arguments (once per session)."""
    key = json.dumps([cwd, deck, args])
    if key not in ctx["refs"]:
        out = os.path.join(ctx["folder"], f"ref-{len(ctx['refs'])}")
        start = time.monotonic()
        r = run(ctx["binary"], [deck, "--out", out, "--force", "--quiet", *args], cwd=cwd)
        ctx["refs"][key] = (out, r, time.monotonic() - start)
    return ctx["refs"][key]


def interrupted(ctx, deck, out, args, sig, delay, started, cwd=None):
    """Starts the run, waits until `started` finds files (or the run ends), then sends sig after delay s; returns
    (exit code, stderr, whether `started` had found files)."""
    p = subprocess.Popen([ctx["binary"], "run", deck, "--out", out, "--force", "--quiet", *args], cwd=cwd,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=ENV)
    for _ in range(6000):
        if started(out) or p.poll() is not None:
            break
        time.sleep(0.01)
    was = bool(started(out))  # (a finished stage removes its checkpoint: a later kill still tests the resume)
    time.sleep(delay)
    if p.poll() is None:
        p.send_signal(sig)
    _, err = p.communicate(timeout=600)
    return p.returncode, err, was


def continue_as_printed(ctx, err, cwd):
    m = re.search(r"Continue with: (celldem run .*? --resume)", err)
    if not m:
        return None, "no 'Continue with: ... --resume' line"
    words = shlex.split(m.group(1))
    r = subprocess.run([ctx["binary"], *words[1:]], cwd=cwd, capture_output=True, text=True, env=ENV, timeout=600)
    return r, m.group(1)


def trial_continue(rng, ctx, tag):
    kind = rng.choice(["axial", "extension", "shear"])
    t = test_of(rng, kind, name="t", steps=rng.choice([2000, 3000]))
    tolerance = rng.choice(["1", "2", "3"])
    seeds = rng.choice(["1-2", "2-3"])
    cwd = os.path.join(ctx["folder"], tag)
    os.makedirs(cwd, exist_ok=True)
    write(os.path.join(cwd, "deck.json"), deck_with([t]))
    args = ["--tolerance", tolerance, "--seeds", seeds, "--threads", "1"]
    ref, r0, span = reference(ctx, "deck.json", args, cwd)
    what = f"--tolerance {tolerance} --seeds {seeds} on a {kind} test; deck {cwd}/deck.json"
    if r0.returncode:
        return "failed", f"{what}: the uninterrupted run exited {r0.returncode}: {r0.stderr[-600:]}"
    out = rng.choice(["c c", "run"])  # a folder name with a space: the printed command must quote it
    delay = rng.uniform(0.0, 0.9 * span)  # from the first seed's start, over the uninterrupted run's time
    rc, err, was = interrupted(ctx, "deck.json", out, args, signal.SIGINT, delay,
                               lambda o: glob.glob(os.path.join(cwd, o, "seed-*", "progress.json")), cwd=cwd)
    if rc != 130 or not was:
        return "skipped", f"{what}: SIGINT at {delay:.2f} s: exit {rc}, run started {was}"
    r, line = continue_as_printed(ctx, err, cwd)
    if r is None:
        return "failed", f"{what}: SIGINT at {delay:.2f} s: {line}: {err[-400:]}"
    if r.returncode:
        return "failed", f"{what}: SIGINT at {delay:.2f} s; `{line}` (in {cwd}) exited {r.returncode}: {r.stderr[-600:]}"
    bad = differences(ref, os.path.join(cwd, out))
    return ("failed", f"{what}: SIGINT at {delay:.2f} s, continued by `{line}`: " + "; ".join(bad[:4])) if bad else \
        ("passed", f"{what}: SIGINT at {delay:.2f} s")


def trial_resume(rng, ctx, tag):
    kind = rng.choice(["axial", "extension"])
    t = test_of(rng, kind, steps=3000)
    inc = t["axes"]["x1"]["strain_increment"]
    t["snapshots"] = {"e1": sorted({round(inc * n, 9) for n in (rng.randint(1, 1000), rng.randint(1000, 2900))},
                                   key=abs), "format": rng.choice(["binary", "zlib", "ascii"])}
    cwd = os.path.join(ctx["folder"], tag)
    os.makedirs(cwd, exist_ok=True)
    deck = write(os.path.join(cwd, "deck.json"), deck_with([t], ctx["state"], checkpoint_interval=rng.choice([200, 500])))
    ref, r0, span = reference(ctx, deck, [], cwd)
    what = f"{kind} with snapshots by e1 {t['snapshots']['e1']}; deck {deck}"
    if r0.returncode:
        return "failed", f"{what}: the uninterrupted run exited {r0.returncode}: {r0.stderr[-600:]}"
    sig = rng.choice([signal.SIGINT, signal.SIGKILL])
    delay = rng.uniform(0.0, 0.7 * span)  # from the test's first checkpoint
    out = os.path.join(cwd, "run")
    rc, err, was = interrupted(ctx, deck, out, [], sig, delay,
                               lambda o: [os.path.join(o, "t", "checkpoint.state")] if os.path.exists(
                                   os.path.join(o, "t", "checkpoint.state")) else [])
    what += f"; {sig.name} at {delay:.2f} s"
    if rc != (130 if sig == signal.SIGINT else -9) or not was:
        return "skipped", f"{what}: exit {rc}, a checkpoint of the test then: {was}"
    if sig == signal.SIGINT:
        r, line = continue_as_printed(ctx, err, cwd)
        if r is None:
            return "failed", f"{what}: {line}: {err[-400:]}"
    else:
        line = f"celldem run {deck} --out {out} --resume"
        r = run(ctx["binary"], [deck, "--out", out, "--resume", "--quiet"])
    if r.returncode:
        return "failed", f"{what}: `{line}` exited {r.returncode}: {r.stderr[-600:]}"
    bad = differences(ref, out)
    if bad and zero_forces(os.path.join(out, "t", "snapshots")):
        bad.insert(0, END_SNAPSHOT_WITHOUT_FORCES)
    return ("failed", f"{what}; `{line}`: " + "; ".join(bad[:4])) if bad else ("passed", what)


# What this harness found (fixed since: no checkpoint is written at a step where a leg ends): a run killed after its
# test's last checkpoint, when that checkpoint was at the test's last step, resumed from it with no step left to take
# and wrote the end snapshot from the checkpoint's state, which holds no pair forces (fx fy fz, the particle stresses
# and the contact forces all 0). Named in a failure's detail when it comes back.
END_SNAPSHOT_WITHOUT_FORCES = "[end snapshot without forces after a resume at the last step]"


def zero_forces(folder):
    """Whether the stage's last .dump snapshot has every force column 0 (False without one)."""
    dumps = sorted((int(n.rsplit("_", 1)[1][:-5]), n) for n in os.listdir(folder) if n.endswith(".dump")) \
        if os.path.isdir(folder) else []
    if not dumps:
        return False
    with open(os.path.join(folder, dumps[-1][1])) as f:
        lines = f.read().splitlines()
    at = next(i for i, line in enumerate(lines) if line.startswith("ITEM: ATOMS"))
    cols = lines[at].split()[2:]
    k = cols.index("fx")
    return all(float(v) == 0.0 for line in lines[at + 1:] for v in line.split()[k:k + 3])


TRIALS = {"probes": trial_probes, "rate": trial_rate, "continue": trial_continue, "resume": trial_resume}


def run_trial(seed, index, ctx):
    import random
    rng = random.Random(f"{seed}-{index}")
    kind = KINDS[index % len(KINDS)]
    tag = f"{kind}-{seed}-{index}"
    try:
        verdict, detail = TRIALS[kind](rng, ctx, tag)
    except subprocess.TimeoutExpired as e:
        verdict, detail = "failed", f"ran past its time limit: {e}"
    return kind, verdict, detail


def context(binary, folder):
    folder = os.path.abspath(folder)
    return {"binary": os.path.abspath(binary), "folder": folder, "state": prepare_sample(os.path.abspath(binary), folder),
            "refs": {}}


def main(argv=None):
    p = argparse.ArgumentParser(description="Seeded trials of features that meet, judged by their invariants.")
    p.add_argument("--draws", type=int, default=8)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--first", type=int, default=0)
    p.add_argument("--binary", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "build",
                                                    "celldem"))
    p.add_argument("--out", help="folder for the sample, decks and runs (default: a new temporary folder)")
    p.add_argument("--kinds", nargs="+", choices=KINDS, default=list(KINDS),
                   help="run only the trials of these kinds (the others of the range are not run; indices unchanged)")
    p.add_argument("--verbose", action="store_true")
    a = p.parse_args(argv)
    ctx = context(a.binary, a.out or tempfile.mkdtemp(prefix="celldem-combinations-"))
    counts = {k: {"passed": 0, "skipped": 0, "failed": 0} for k in KINDS}
    ran = 0
    for i in range(a.first, a.first + a.draws):
        if KINDS[i % len(KINDS)] not in a.kinds:
            continue
        ran += 1
        kind, verdict, detail = run_trial(a.seed, i, ctx)
        counts[kind][verdict] += 1
        if verdict == "failed" or a.verbose:
            print(f"trial seed {a.seed} index {i} {kind} [{verdict}] {detail}", flush=True)
    total = {v: sum(c[v] for c in counts.values()) for v in ("passed", "skipped", "failed")}
    for k in a.kinds:
        print(f"  {k:9s} " + ", ".join(f"{n} {v}" for v, n in counts[k].items()))
    print(f"{ran} trials (seed {a.seed}, from {a.first}, of {a.draws} drawn): {total['passed']} passed, {total['skipped']} skipped, "
          f"{total['failed']} failed; files in {ctx['folder']}")
    return 1 if total["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
