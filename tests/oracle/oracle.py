#!/usr/bin/python3
"""An independent check of a run's summary.json against its series and its deck.

From a run directory's `<test>/series.csv`, its leg-end rows and the deck that ran (`resolved_deck.json`, else the
deck given, else the canonical deck in `progress.json`), this re-derives what `summary.json` claims of each test and
lists every disagreement:

- controls: for each controlled component of each leg (x1 x2 x3 on stress, stress_ramp, mean_stress, b or
  constant_volume; x12 x13 x23 on stress, zero_shear_stress included; the moving targets of a principal-axis
  rotation) its worst error against its target at the rows after the leg's settle window. The solver checks every
  step and the series holds every output_interval-th, so the rows' error is a lower bound of the claimed one: a
  claimed null error where rows were measured, a claimed error below the rows' beyond round-off, a test maximum
  (servo_max_error, b_max_error, volume_max_error) below the rows', and
  `"controlled": true` while the rows stay beyond the tolerance for longer than the solver's persistence window
  (on at least 5 rows in a row) are disagreements, and so is `"controlled": true` beside a
  `control_error_over_tolerance` above 1 (issue 38: never both);
- ends: each leg's last row satisfies its end condition (and no earlier row of the leg did, for the ends that a
  crossing decides), and summary.json's `legs[].end` is that row;
- peaks: a claimed peak (`peak_reached` true, or `shear.peak_reached`) is not the last row of the measure the test
  drives (s11/s33, s33/s11 in extension; |s_ij|/s_jj of a strain-driven shear axis; s_ii/s_jj of a rotation's
  plane), and "no peak reached" is not said where that measure clearly peaked (fell more than 1 % below its largest
  value and stayed there for 0.5 % of driving strain); `peak_ratio13` is the rows' largest s11/s33.

Nothing of the solver is imported: the rules are re-derived from the deck's keys (docs/deck.md) and the constants
below, each naming the C++ constant it mirrors. Usage: `oracle.py RUN_DIR [--deck DECK]`; exit 0 when the oracle
agrees, 1 when it lists disagreements.
"""

import argparse
import csv
import json
import math
import os
import sys

# The solver's constants (docs/outputs.md, `celldem schema` does not expose them), one place.
SERVO_TOLERANCE = 0.005        # solver/run/health.hpp kServoTolerance: stress, stress_ramp, shear stress axes
MEAN_STRESS_TOLERANCE = 0.005  # kMeanStressTolerance
B_TOLERANCE = 0.01             # kBTolerance (absolute)
VOLUME_TOLERANCE = 1e-6        # kVolumeTolerance
SETTLE_STRAIN = 0.002          # solver/run/program.hpp kSettleStrain
PERSIST_STRAIN = 0.001         # kPersistStrain
MIN_PERSIST_STEPS = 500        # kMinPersistSteps
RAMP_SETTLE_STEPS = 1000       # kRampSettleSteps; the oracle uses it for every leg that no strain drives
PEAK_PLATEAU = 0.01            # solver/run/summary.hpp kPeakPlateau
PEAK_SMOOTHING = 0.005         # kPeakSmoothing (of driving strain)
# "Controlled" is disputed only on this many consecutive rows beyond the tolerance spanning more than the persistence
# window: rows are samples, and a noisy control may dip inside its tolerance between them.
PERSIST_ROWS = 5
# The series holds 10 significant digits: an error re-derived from it differs from the solver's by this much.
ROUND_OFF = 1e-7

NORMAL = ("x1", "x2", "x3")
SHEAR = ("x12", "x13", "x23")
COMPONENTS = NORMAL + SHEAR
SHEAR_ENTRIES = {"x12": (0, 1), "x13": (0, 2), "x23": (1, 2)}  # the normal axes i, j of shear axis ij
PLANE_SHEAR = {"x1x2": "x12", "x1x3": "x13", "x2x3": "x23"}
TOLERANCE = {"stress": SERVO_TOLERANCE, "stress_ramp": SERVO_TOLERANCE, "shear_stress": SERVO_TOLERANCE,
             "mean_stress": MEAN_STRESS_TOLERANCE, "b": B_TOLERANCE, "constant_volume": VOLUME_TOLERANCE}


# ---------------------------------------------------------------------------------------------------- the deck
def expand_legs(test):
    """The test's legs in order (repeat blocks expanded); a single-leg test is one leg."""
    if "legs" not in test:
        return [test]
    out = []

    def walk(items):
        for item in items:
            if "repeat" in item:
                for _ in range(int(item["repeat"])):
                    walk(item["legs"])
            else:
                out.append(item)
    walk(test["legs"])
    return out


class Control:
    """One component's control in a leg: kind (stress, stress_ramp, mean_stress, b, constant_volume, shear_stress,
    strain, held) and what its target needs."""

    def __init__(self, kind, value=0.0, rate=0.0):
        self.kind, self.value, self.rate = kind, value, rate


class Leg:
    def __init__(self, raw, dt):
        self.raw, self.dt = raw, dt
        self.controls = {}
        self.rotation = None
        self.adaptive = "adaptive_rate" in raw
        self.end = raw.get("end", {})
        if "simple_shear" in raw:
            s = raw["simple_shear"]
            self.controls = {"x1": Control("strain"), "x2": Control("stress", s["normal_stress"]), "x3": Control("strain"),
                             "x12": Control("strain", *self._per_step(s, "gamma_increment", "gamma_rate")),
                             "x13": Control("held"), "x23": Control("held")}
        else:
            axes = raw.get("axes", {})
            for name in COMPONENTS:
                a = axes.get(name)
                self.controls[name] = self._control(a) if a is not None else Control("held")
                if name in SHEAR and self.controls[name].kind == "stress":
                    self.controls[name].kind = "shear_stress"
            if raw.get("zero_shear_stress"):
                for name in SHEAR:
                    self.controls[name] = Control("shear_stress", 0.0)
            if "rotate_principal_axes" in raw:
                r = raw["rotate_principal_axes"]
                by_rate = "rate" in r
                rate = math.radians(r["rate"] if by_rate else r["angle_increment"])
                self.rotation = {"shear": PLANE_SHEAR[r["plane"]], "sigma1": r["sigma1"], "sigma3": r["sigma3"],
                                 "from": math.radians(r.get("from", 0.0)), "rate": rate, "per_step": not by_rate}
                i, j = SHEAR_ENTRIES[self.rotation["shear"]]
                self.controls[NORMAL[i]] = Control("rotation_ii")
                self.controls[NORMAL[j]] = Control("rotation_jj")
                self.controls[self.rotation["shear"]] = Control("rotation_ij")

    @staticmethod
    def _per_step(a, inc, rate):
        return (a[inc], 0.0) if inc in a else (0.0, a[rate])

    def _control(self, a):
        if "strain_increment" in a:
            return Control("strain", a["strain_increment"])
        if "strain_rate" in a:
            return Control("strain", 0.0, a["strain_rate"])
        if "stress_ramp" in a:
            return Control("stress_ramp", a["stress_ramp"]["from"], a["stress_ramp"]["rate"])
        for kind in ("stress", "mean_stress", "b"):
            if kind in a:
                return Control(kind, a[kind])
        if "constant_volume" in a:
            return Control("constant_volume")
        raise ValueError(f"unknown axis control {a}")

    def strain_per_step(self, name):
        c = self.controls[name]
        return c.value + c.rate * self.dt if c.kind == "strain" else 0.0

    def driving(self):
        """The largest |strain per step| of a strain-driven component, normal or shear (0: nothing drives it)."""
        return max(abs(self.strain_per_step(n)) for n in COMPONENTS)

    def settle_steps(self):
        d = self.driving()
        return math.ceil(SETTLE_STRAIN / d * (1 - 1e-12)) if d > 0 else RAMP_SETTLE_STEPS

    def persist_steps(self):
        d = self.driving()
        return max(MIN_PERSIST_STEPS, math.ceil(PERSIST_STRAIN / d * (1 - 1e-12))) if d > 0 else MIN_PERSIST_STEPS

    def rotation_targets(self, leg_time):
        r = self.rotation
        theta = r["from"] + (r["rate"] * leg_time / self.dt if r["per_step"] else r["rate"] * leg_time)
        m, h = 0.5 * (r["sigma1"] + r["sigma3"]), 0.5 * (r["sigma1"] - r["sigma3"])
        return m + h * math.cos(2 * theta), m - h * math.cos(2 * theta), h * math.sin(2 * theta)

    def controlled(self):
        """The components whose error the leg must report: (name, kind for the tolerance)."""
        out = []
        for name in COMPONENTS:
            kind = self.controls[name].kind
            if kind in ("stress", "stress_ramp", "mean_stress", "b", "constant_volume"):
                out.append((name, kind if name in NORMAL else "shear_stress"))
            elif kind in ("shear_stress", "rotation_ij"):
                out.append((name, "shear_stress"))
            elif kind in ("rotation_ii", "rotation_jj"):
                out.append((name, "stress"))
        return out

    def error(self, name, row, leg_time, start_row):
        """The component's error at a row (NaN where it has none there)."""
        c = self.controls[name]
        s = [row["s11"], row["s22"], row["s33"]]
        if name in SHEAR:
            if c.kind not in ("shear_stress", "rotation_ij"):
                return math.nan
            goal = c.value if c.kind == "shear_stress" else self.rotation_targets(leg_time)[2]
            return abs(row["s" + name[1:]] - goal) / max(abs(goal), sum(s) / 3)
        k = NORMAL.index(name)
        if c.kind in ("stress", "stress_ramp", "rotation_ii", "rotation_jj"):
            target = (c.value + c.rate * leg_time if c.kind == "stress_ramp" else c.value if c.kind == "stress"
                      else self.rotation_targets(leg_time)[0 if c.kind == "rotation_ii" else 1])
            return abs(s[k] / target - 1)
        if c.kind == "mean_stress":
            return abs(sum(s) / 3 / c.value - 1)
        if c.kind == "constant_volume":  # V = V0 (1 - ev), V0 the stage start's
            return abs((1 - row["ev"]) / (1 - start_row["ev"]) - 1)
        if c.kind == "b":  # s_minor: the (last) other stress or mean-stress axis; s_major: the strain-driven one
            minor = [m for m in range(3) if self.controls[NORMAL[m]].kind in ("stress", "mean_stress")]
            major = [m for m in range(3) if self.controls[NORMAL[m]].kind == "strain"]
            if not minor or not major:
                return math.nan
            den = s[major[0]] - s[minor[-1]]
            return abs((s[k] - s[minor[-1]]) / den - c.value) if den != 0 else math.nan
        return math.nan


def load_deck(run_dir, deck_path=None):
    resolved = os.path.join(run_dir, "resolved_deck.json")
    if os.path.exists(resolved):
        with open(resolved) as f:
            return json.load(f)
    if deck_path:
        with open(deck_path) as f:
            return json.load(f)
    with open(os.path.join(run_dir, "progress.json")) as f:
        return json.loads(json.load(f)["deck"])


def read_series(path):
    with open(path, newline="") as f:
        rows = []
        for r in csv.DictReader(f):
            rows.append({k: float(v) if v not in ("", None) else math.nan for k, v in r.items()})
    return rows


# ------------------------------------------------------------------------------------------------- the claims
def claimed_axes(record):
    """summary.json's per-component control record of a leg, by component name: either layout (3 `axes` plus
    optional `shear_axes`, or 6 `axes` in Voigt order, entries optionally named)."""
    out = {}
    axes = record.get("axes", [])
    for i, a in enumerate(axes):
        name = a.get("name") or (COMPONENTS[i] if i < 6 else None)
        if name:
            out[name] = a
    for i, a in enumerate(record.get("shear_axes", []) or []):
        out[a.get("name") or SHEAR[i]] = a
    return out


def num(x):
    return x if isinstance(x, (int, float)) and x is not None and math.isfinite(x) else math.nan


def below(claimed, measured):
    """Whether a claimed worst error is below the rows' beyond round-off."""
    return claimed < measured - ROUND_OFF - 1e-6 * measured


# ---------------------------------------------------------------------------------------------------- the check
def check_test(name, test, deck, summary_test, rows, problems):
    def say(msg):
        problems.append(f"test '{name}': {msg}")

    dt = test.get("time_step", deck["time_step"])
    legs = [Leg(raw, dt) for raw in expand_legs(test)]
    claimed_legs = summary_test.get("legs", [])
    if len(claimed_legs) != len(legs):
        say(f"summary.json has {len(claimed_legs)} legs, the deck {len(legs)}")
    start_row = rows[0]  # the stage start (the volume's reference)
    maxima = {"servo": math.nan, "b": math.nan, "volume": math.nan}
    any_failure_claimed = bool(summary_test.get("control_failures"))
    prev_end = rows[0]
    for k, leg in enumerate(legs):
        leg_rows = [r for r in rows if int(r["leg"]) == k]
        if not leg_rows:
            say(f"leg {k}: no series row")
            continue
        end_row = max(leg_rows, key=lambda r: r["step"])
        leg_start = prev_end["step"] if k > 0 else 0.0
        claimed = claimed_legs[k] if k < len(claimed_legs) else {}
        # -- controls
        record = claimed.get("control_errors") or {}
        axes = claimed_axes(record)
        settle, persist = leg.settle_steps(), leg.persist_steps()
        interval = leg_rows[1]["step"] - leg_rows[0]["step"] if len(leg_rows) > 1 else 0
        for comp, kind in leg.controlled():
            tol = TOLERANCE[kind]
            worst, run_first, run_rows, longest = math.nan, None, 0, 0.0
            for r in leg_rows:
                n = r["step"] - leg_start
                if n < settle:
                    continue
                e = leg.error(comp, r, n * dt, prev_end if kind == "constant_volume" else start_row)
                if not math.isfinite(e):
                    continue
                worst = e if not math.isfinite(worst) else max(worst, e)
                if e > tol:
                    run_first = r["step"] if run_first is None else run_first
                    run_rows += 1
                    if run_rows >= PERSIST_ROWS:
                        longest = max(longest, r["step"] - run_first)
                else:
                    run_first, run_rows = None, 0
            if not math.isfinite(worst):
                continue
            unit = "servo" if kind in ("stress", "stress_ramp", "mean_stress", "shear_stress") else \
                   "b" if kind == "b" else "volume"
            maxima[unit] = worst if not math.isfinite(maxima[unit]) else max(maxima[unit], worst)
            what = f"leg {k} component {comp} ({leg.controls[comp].kind}"
            what += f", target {leg.controls[comp].value:g})" if leg.controls[comp].kind in ("stress", "shear_stress", "mean_stress", "b") else ")"
            c = num((axes.get(comp) or {}).get("error"))
            if not math.isfinite(c):
                say(f"{what}: claimed error null, the rows show {worst:.4g} (tolerance {tol:g})")
            elif below(c, worst):
                say(f"{what}: claimed error {c:.4g} below the rows' {worst:.4g}")
            if longest > persist and not any_failure_claimed and summary_test.get("controlled") is True:
                say(f"{what}: \"controlled\": true while the rows stay beyond the tolerance {tol:g} for "
                    f"{longest:.0f} steps (persistence window {persist}, rows every {interval:.0f}; worst {worst:.4g})")
        # -- the leg's end
        check_end(k, leg, leg_rows, end_row, leg_start, rows, claimed, say, equilibrium_of(deck, test))
        prev_end = end_row
    # -- the test's maxima
    # (control_error_over_tolerance is not compared: it may judge an error sustained over the persistence window,
    # which single rows do not bound)
    for key, unit in (("servo_max_error", "servo"), ("b_max_error", "b"), ("volume_max_error", "volume")):
        if not math.isfinite(maxima[unit]):
            continue
        c = num(summary_test.get(key))
        if not math.isfinite(c):
            say(f"{key} claimed null, the rows show {maxima[unit]:.4g}")
        elif below(c, maxima[unit]):
            say(f"{key} claimed {c:.4g}, below the rows' {maxima[unit]:.4g}")
    if summary_test.get("controlled") is True and summary_test.get("control_failures"):
        say("\"controlled\": true beside control_failures")
    over = num(summary_test.get("control_error_over_tolerance"))
    if summary_test.get("controlled") is True and over > 1:  # issue 38: never both
        say(f"\"controlled\": true beside control_error_over_tolerance {over:.4g} (above 1)")
    check_peak(legs, rows, summary_test, say)


def equilibrium_of(deck, test):
    """A test's equilibrium criterion: tests[].equilibrium, each key defaulting to prepare.equilibrium's, then to the
    deck's defaults (docs/deck.md)."""
    out = {"stress_tolerance": 0.005, "pressure_tolerance": 0.005, "min_steps": 20000, "check_interval": 1000}
    out.update((deck.get("prepare") or {}).get("equilibrium", {}))
    out.update(test.get("equilibrium", {}))
    return out


def check_end(k, leg, leg_rows, end_row, leg_start, rows, claimed, say, equilibrium):
    e = leg.end
    n_end = end_row["step"] - leg_start
    max_steps = e.get("max_steps", 0)
    where = f"leg {k} end"
    crossing = None  # (value of a row, target, start value) for ends decided by a crossing
    if "steps" in e:
        want = min(e["steps"], max_steps) if max_steps else e["steps"]
        if n_end != want:
            say(f"{where}: steps {e['steps']}, the leg's last row is {n_end:.0f} steps in")
    elif "strain" in e:
        axis = e.get("axis", "x1")
        col = "g" + axis[1:] if axis in SHEAR else "e" + axis[1:]
        per_step = leg.strain_per_step(axis)
        if per_step != 0:
            if not (max_steps and n_end >= max_steps) and abs(end_row[col] - e["strain"]) > 0.5 * abs(per_step) + 1e-9:
                say(f"{where}: strain {e['strain']:g} on {axis}, the last row has {col} = {end_row[col]:.6g}")
        else:
            crossing = (col, e["strain"])
    elif "ratio" in e:
        crossing = ("ratio13", e["ratio"])
    elif "stress" in e:
        crossing = ("s" + 2 * e.get("axis", "x1")[1], e["stress"])
    elif e.get("equilibrium"):  # at a check, past min_steps, each stress axis within the stress tolerance (the
        # unbalanced force is measured on the step, not written exactly enough to decide it)
        if not (max_steps and n_end >= max_steps):
            if n_end < equilibrium["min_steps"] or n_end % equilibrium["check_interval"]:
                say(f"{where}: equilibrium reached {n_end:.0f} steps in, not at a check past min_steps "
                    f"{equilibrium['min_steps']} (every {equilibrium['check_interval']})")
            for i, name in enumerate(NORMAL):
                c = leg.controls[name]
                if c.kind == "stress" and abs(end_row[f"s{i + 1}{i + 1}"] / c.value - 1) > equilibrium["stress_tolerance"] + ROUND_OFF:
                    say(f"{where}: equilibrium claimed with {name} at {end_row[f's{i + 1}{i + 1}']:.6g} Pa against "
                        f"{c.value:g} (stress_tolerance {equilibrium['stress_tolerance']:g})")
    if crossing:
        col, target = crossing
        start = ([r for r in rows if r["step"] == leg_start] or leg_rows)[0][col]
        side = 1 if start < target else -1
        reached = [r for r in leg_rows if side * (r[col] - target) >= 0 and r["step"] > leg_start]
        if not (max_steps and n_end >= max_steps):
            if not reached or reached[0]["step"] != end_row["step"]:
                first = f"first reached at step {reached[0]['step']:.0f}" if reached else "never reached"
                say(f"{where}: {col} {target:g} {first}, the leg's last row is step {end_row['step']:.0f}")
    # summary.json's legs[].end is the leg's last row
    claimed_end = claimed.get("end")
    if claimed_end:
        for key in ("step", "e1", "e2", "e3", "s11", "s22", "s33", "ev"):
            c = num(claimed_end.get(key))
            if math.isfinite(c) and abs(c - end_row[key]) > 1e-8 * max(1.0, abs(end_row[key])):
                say(f"{where}: summary's {key} {c:.10g}, the last row's {end_row[key]:.10g}")


def driven_measure(legs, rows):
    """The measure the test drives, per row, its name, and the driving coordinate per row (the driven strain; None for
    a test that no strain drives; all None for a test that drives nothing), from its first leg that drives something: s_ii/s_jj of a rotation's plane, else by
    the fastest strain-driven component: |s_ij|/s_jj of a shear axis (the shear stress over the normal stress of its
    plane), s11/s33 (s33/s11 when x1 is extended)."""
    def ratio(a, b):
        return [r[a] / r[b] if r[b] else math.nan for r in rows]
    for leg in legs:  # the first leg that drives something, by its fastest strain-driven component
        if leg.rotation:
            i, j = SHEAR_ENTRIES[leg.rotation["shear"]]
            a, b = "s" + str(i + 1) * 2, "s" + str(j + 1) * 2
            return f"{a}/{b}", ratio(a, b), None
        if leg.driving() == 0:
            continue
        name = max(COMPONENTS, key=lambda n: abs(leg.strain_per_step(n)))
        if name in SHEAR:
            col, den = "s" + name[1:], "s" + str(SHEAR_ENTRIES[name][1] + 1) * 2
            return f"|{col}|/{den}", [abs(r[col]) / r[den] if r[den] else math.nan for r in rows], \
                [abs(r["g" + name[1:]]) for r in rows]
        col = "e" + name[1:]
        if name == "x1" and leg.strain_per_step(name) < 0:
            return "s33/s11", ratio("s33", "s11"), [abs(r[col]) for r in rows]
        return "s11/s33", [r["ratio13"] for r in rows], [abs(r[col]) for r in rows]
    return None, None, None  # stresses held or ramped only: no driven measure, no peak to judge


# The record of a shear or an extension test: its key in summary.json, its peak value's key and its at-peak strain's
# key with the series column that strain is read from.
DRIVEN_RECORDS = {"shear": ("peak_tau_over_sigma_n", "g_at_peak"), "extension": ("peak_ratio31", "e1_at_peak")}


def claimed_record(summary_test):
    """The shear or extension record of a test (its key and the record), else (None, None)."""
    for key in DRIVEN_RECORDS:
        if isinstance(summary_test.get(key), dict):
            return key, summary_test[key]
    return None, None


def check_peak(legs, rows, summary_test, say):
    name, m, coordinate = driven_measure(legs, rows)
    key, record = claimed_record(summary_test)
    claimed_name = summary_test.get("driven_measure")
    if name and claimed_name and "/" in claimed_name and claimed_name != name:
        say(f"driven_measure {claimed_name!r}, the deck drives {name}")
    ratio = [r["ratio13"] for r in rows if math.isfinite(r["ratio13"])]
    c = num(summary_test.get("peak_ratio13"))
    if record is not None:  # a shear or extension test: its peak is the driven measure's, in its record
        if summary_test.get("peak_ratio13") is not None:
            say(f"a {key} test's top-level peak_ratio13 is {summary_test['peak_ratio13']}, not null (its peak is "
                f"{key}.{DRIVEN_RECORDS[key][0]})")
    elif ratio and math.isfinite(c) and abs(c - max(ratio)) > 1e-8 * max(ratio):
        say(f"peak_ratio13 {c:.10g}, the rows' largest s11/s33 {max(ratio):.10g}")
    if name is None:
        return
    finite = [(v, i) for i, v in enumerate(m) if math.isfinite(v)]
    claim = (record or summary_test).get("peak_reached")
    if len(finite) < 3 or claim is None:
        return
    top = max(v for v, _ in finite)
    first_top = min(i for v, i in finite if v == top)
    peak_row = rows[first_top]
    if record is not None:
        value_key, at_key = DRIVEN_RECORDS[key]
        v = num(record.get(value_key))
        if not math.isfinite(v) or abs(v - top) > 1e-7 * abs(top):
            say(f"{key}.{value_key} {record.get(value_key)}, the rows' largest {name} {top:.10g}")
        col = "e1" if key == "extension" else "g" + name[2:4]
        at = num(record.get(at_key))
        if not math.isfinite(at) or abs(abs(at) - abs(peak_row[col])) > 1e-9 + 1e-8 * abs(peak_row[col]):
            say(f"{key}.{at_key} {record.get(at_key)}, the row of the largest {name} has {col} {peak_row[col]:.10g}")
    # The test's own at-peak keys sit on the driven measure's peak row (a rotation's peak is judged by the solver on
    # another measure: left out).
    if not name.startswith("s") or name == "s11/s33" or key == "extension":
        e1 = num(summary_test.get("e1_at_peak"))
        if math.isfinite(e1) and abs(e1 - peak_row["e1"]) > 1e-9 + 1e-8 * abs(peak_row["e1"]):
            say(f"e1_at_peak {e1:.10g}, the row of the largest {name} (step {peak_row['step']:.0f}) has e1 "
                f"{peak_row['e1']:.10g}")
        state = summary_test.get("peak_state") or {}
        for k, col in (("ev", "ev"), ("p", "p")):
            v = num(state.get(k))
            if math.isfinite(v) and abs(v - peak_row[col]) > 1e-9 + 1e-7 * abs(peak_row[col]):
                say(f"peak_state.{k} {v:.10g}, the row of the largest {name} (step {peak_row['step']:.0f}) has "
                    f"{peak_row[col]:.10g}")
    if claim is True and first_top == finite[-1][1]:
        say(f"a peak is claimed, but the driven measure {name} is largest at the last row ({top:.4g})")
    # "No peak reached" is disputed only where the peak is clear: after the largest value (not the test's first row)
    # the measure falls more than the plateau's 1 % and stays down for the summary's smoothing span of driving strain
    # (kPeakSmoothing), or for a tenth of the rows where no strain drives the test.
    if claim is False and first_top > 0:
        after = [i for v, i in finite if i > first_top and
                 (coordinate[i] - coordinate[first_top] >= PEAK_SMOOTHING if coordinate else
                  i - first_top >= len(rows) / 10)]
        if after and all(m[i] < (1 - PEAK_PLATEAU) * top for v, i in finite if i >= after[0]):
            say(f"\"no peak reached\" (peak_reached false), but the driven measure {name} peaks at {top:.4g} "
                f"(row step {rows[first_top]['step']:.0f}) and stays below {1 - PEAK_PLATEAU:g} of it from step "
                f"{rows[after[0]]['step']:.0f} to the end ({finite[-1][0]:.4g})")


def check_run(run_dir, deck_path=None):
    """Every disagreement between the run's summary.json and what its series and deck show (empty: it agrees)."""
    deck = load_deck(run_dir, deck_path)
    with open(os.path.join(run_dir, "summary.json")) as f:
        summary = json.load(f)
    problems = []
    for test in deck.get("tests", []):
        name = test["name"]
        claimed = summary.get("tests", {}).get(name)
        series = os.path.join(run_dir, name, "series.csv")
        if claimed is None or not os.path.exists(series):
            problems.append(f"test '{name}': no summary or no series.csv")
            continue
        rows = read_series(series)
        if not rows:
            problems.append(f"test '{name}': empty series")
            continue
        check_test(name, test, deck, claimed, rows, problems)
    return problems


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("run_dir")
    p.add_argument("--deck", help="the deck that ran, when the run has no resolved_deck.json")
    a = p.parse_args(argv)
    problems = check_run(a.run_dir, a.deck)
    for m in problems:
        print(m)
    print(f"oracle: {len(problems)} disagreement(s) in {a.run_dir}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
