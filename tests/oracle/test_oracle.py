"""The result oracle (oracle.py) on synthetic run folders whose series and deck are known: it agrees with a true
summary, in either control-record layout, and names each disagreement planted in a copy of it."""

import copy
import csv
import json
import math
import os

import pytest

import oracle

DT = 1e-6
COLUMNS = ["step", "time", "e1", "e2", "e3", "ev", "s11", "s22", "s33", "s12", "s13", "s23", "p", "ratio13", "leg",
           "g12", "g13", "g23"]


def triaxial_rows(n_rows=31, interval=100, x22_wobble=2e-3, s12=2e4):
    """A triaxial leg: x1 at 1e-5 per step, s22 = s33 = 1e5 held (s22 off by up to x22_wobble), s12 held near
    s12, and s11/s33 peaking mid-test."""
    rows = []
    for r in range(n_rows):
        step = r * interval
        e1 = 1e-5 * step
        s11 = 1e5 * (1 + 0.8 * math.sin(math.pi * r / (n_rows - 1) * 0.75))
        s22 = 1e5 * (1 + x22_wobble * math.sin(r))
        s33 = 1e5
        rows.append({"step": step, "time": step * DT, "e1": e1, "e2": -0.3 * e1, "e3": -0.3 * e1, "ev": 0.4 * e1,
                     "s11": s11, "s22": s22, "s33": s33, "s12": s12 * (1 + 1e-3 * math.cos(r)), "s13": 0.0, "s23": 0.0,
                     "p": (s11 + s22 + s33) / 3, "ratio13": s11 / s33, "leg": 0, "g12": 0.0, "g13": 0.0, "g23": 0.0})
    return rows


DECK = {"format": 1, "time_step": DT, "tests": [{
    "name": "t", "friction": 0.5, "output_interval": 100,
    "axes": {"x1": {"strain_increment": 1e-5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}, "x12": {"stress": 2e4}},
    "end": {"axis": "x1", "strain": 0.03}}]}


def true_summary(rows, six=False):
    """What a correct solver could claim of the rows (its per-step errors at least the rows')."""
    settle = 200  # kSettleStrain / 1e-5
    counted = [r for r in rows if r["step"] >= settle]
    e2 = max(abs(r["s22"] / 1e5 - 1) for r in counted) * 1.01
    e3 = max(abs(r["s33"] / 1e5 - 1) for r in counted)
    e12 = max(abs(r["s12"] - 2e4) / max(2e4, r["p"]) for r in counted) * 1.01
    axis = {"saturated_steps": 0, "over_steps": 0, "over_saturated": 0, "failed": False}
    normal = [dict(axis, error=None), dict(axis, error=e2), dict(axis, error=e3)]
    shear = [dict(axis, error=e12), dict(axis, error=None), dict(axis, error=None)]
    record = {"stress": max(e2, e3), "b": None, "mean_stress": None, "volume": None, "steps": 2801}
    if six:
        record["axes"] = [dict(a, name=n) for a, n in zip(normal + shear, oracle.COMPONENTS)]
    else:
        record.update(axes=normal, shear_axes=shear, shear_stress=e12)
    last = rows[-1]
    top = max(range(len(rows)), key=lambda i: rows[i]["ratio13"])
    end = {k: last[k] for k in ("step", "e1", "e2", "e3", "s11", "s22", "s33", "ev")}
    return {"tests": {"t": {
        "controlled": True, "control_failures": [], "servo_max_error": max(e2, e3, e12), "b_max_error": None,
        "volume_max_error": None, "control_error_over_tolerance": max(e2, e3, e12) / 0.005,
        "peak_ratio13": rows[top]["ratio13"], "peak_reached": True,
        "legs": [{"leg": 0, "end": end, "control_errors": record}]}}}


def write_run(folder, rows, summary, deck=DECK):
    os.makedirs(os.path.join(folder, "t"), exist_ok=True)
    with open(os.path.join(folder, "t", "series.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS)
        w.writeheader()
        for r in rows:
            w.writerow({k: f"{v:.10g}" for k, v in r.items()})
    with open(os.path.join(folder, "summary.json"), "w") as f:
        json.dump(summary, f)
    with open(os.path.join(folder, "resolved_deck.json"), "w") as f:
        json.dump(deck, f)
    return str(folder)


@pytest.mark.parametrize("six", [False, True], ids=["axes+shear_axes", "six-axes"])
def test_agrees_with_a_true_summary(tmp_path, six):
    rows = triaxial_rows()
    assert oracle.check_run(write_run(tmp_path, rows, true_summary(rows, six))) == []


def leg_record(summary):
    return summary["tests"]["t"]["legs"][0]["control_errors"]


def entry(record, name):
    return oracle.claimed_axes(record)[name]


def plant(kind, summary, six):
    """Plants one false claim; returns the words its disagreement must hold."""
    t = summary["tests"]["t"]
    rec = leg_record(summary)
    if kind == "null_shear_error":  # the held x12 recorded as null (issue 38)
        entry(rec, "x12")["error"] = None
        return ["x12", "null"]
    if kind == "no_shear_record":  # a 3-entry layout without shear_axes: x12 unreported
        if six:
            rec["axes"] = rec["axes"][:3]
        else:
            del rec["shear_axes"]
        return ["x12", "null"]
    if kind == "low_error":
        entry(rec, "x2")["error"] *= 0.5
        return ["x2", "below the rows"]
    if kind == "low_servo_max":
        t["servo_max_error"] = 1e-6
        return ["servo_max_error"]
    if kind == "peak_at_end":  # a peak claimed where s11/s33 rises to the last row
        return None
    if kind == "no_peak":
        t["peak_reached"] = False
        return ["no peak", "s11/s33"]
    if kind == "end_row":
        t["legs"][0]["end"]["s22"] *= 1.01
        return ["leg 0 end", "s22"]
    if kind == "controlled_and_over":
        t["control_error_over_tolerance"] = 54.9
        return ["controlled", "54.9"]
    raise ValueError(kind)


@pytest.mark.parametrize("six", [False, True], ids=["axes+shear_axes", "six-axes"])
@pytest.mark.parametrize("kind", ["null_shear_error", "no_shear_record", "low_error", "low_servo_max", "no_peak",
                                  "end_row", "controlled_and_over"])
def test_names_a_planted_disagreement(tmp_path, kind, six):
    rows = triaxial_rows()
    summary = true_summary(rows, six)
    words = plant(kind, summary, six)
    problems = oracle.check_run(write_run(tmp_path, rows, summary))
    assert len(problems) == 1, problems
    for w in words:
        assert w in problems[0], problems


def test_a_peak_at_the_last_row(tmp_path):
    rows = triaxial_rows()
    for r in rows:  # s11/s33 rising to the end
        r["s11"] = 1e5 * (1 + r["e1"] * 20)
        r["ratio13"] = r["s11"] / r["s33"]
        r["p"] = (r["s11"] + r["s22"] + r["s33"]) / 3
    summary = true_summary(rows)
    problems = oracle.check_run(write_run(tmp_path, rows, summary))
    assert len(problems) == 1 and "largest at the last row" in problems[0], problems
    summary["tests"]["t"]["peak_reached"] = False
    assert oracle.check_run(write_run(tmp_path, rows, summary)) == []


def test_controlled_while_the_rows_stay_out(tmp_path):
    """s22 10 % off for the whole leg (persistence 500 steps at 1e-5 per step): "controlled": true is false, and
    the error the summary claims is the rows' at least."""
    rows = triaxial_rows()
    for r in rows:
        r["s22"] = 1.1e5
    summary = true_summary(rows)
    leg_record(summary)["axes"][1]["error"] = 0.1
    problems = oracle.check_run(write_run(tmp_path, rows, summary))
    assert any("x2" in p and "\"controlled\": true while the rows stay beyond" in p for p in problems), problems
    summary["tests"]["t"].update(controlled=False, control_failures=[{"leg": 0, "axis": "x2", "kind": "stress"}])
    assert oracle.check_run(write_run(tmp_path, rows, summary)) == []


def test_an_end_not_reached(tmp_path):
    rows = triaxial_rows()
    deck = copy.deepcopy(DECK)
    deck["tests"][0]["end"]["strain"] = 0.04  # the rows stop at e1 = 0.03
    problems = oracle.check_run(write_run(tmp_path, rows, true_summary(rows), deck))
    assert len(problems) == 1 and "strain 0.04 on x1" in problems[0], problems


def test_simple_shear_peak_is_tau_over_sigma_n(tmp_path):
    simple_shear_run(tmp_path)


def simple_shear_run(tmp_path):
    """A simple shear's driven measure is |s12|/s22: "no peak reached" is false when it peaks mid-test, whatever
    s11/s33 does (here it rises to the end)."""
    rows = triaxial_rows()
    for i, r in enumerate(rows):
        r["g12"], r["e1"], r["e2"], r["e3"] = r["e1"], 0.0, r["e2"], 0.0
        r["s22"] = 1e5
        r["s12"] = 5e4 * math.sin(math.pi * i / (len(rows) - 1) * 0.7)
        r["s11"] = 1e5 * (1 + 0.01 * i)
        r["ratio13"] = r["s11"] / r["s33"]
        r["p"] = (r["s11"] + r["s22"] + r["s33"]) / 3
    deck = {"format": 1, "time_step": DT, "tests": [{
        "name": "t", "friction": 0.5, "output_interval": 100,
        "simple_shear": {"gamma_increment": 1e-5, "normal_stress": 1e5}, "end": {"axis": "x12", "strain": 0.03}}]}
    summary = true_summary(rows)
    t = summary["tests"]["t"]
    rec = leg_record(summary)
    rec["axes"][1]["error"] = 0.0
    rec["axes"][2]["error"] = None
    del rec["shear_axes"]
    t.update(servo_max_error=0.0, control_error_over_tolerance=0.0, peak_reached=False)
    problems = oracle.check_run(write_run(tmp_path, rows, summary, deck))
    assert len(problems) == 1 and "|s12|/s22" in problems[0] and "no peak" in problems[0], problems
    top = max(range(len(rows)), key=lambda i: abs(rows[i]["s12"]) / rows[i]["s22"])
    t["shear"] = {"peak_reached": True, "peak_tau_over_sigma_n": abs(rows[top]["s12"]) / rows[top]["s22"],
                  "g_at_peak": rows[top]["g12"]}
    t.update(peak_ratio13=None, e1_at_peak=rows[top]["e1"], peak_state={"p": rows[top]["p"], "ev": rows[top]["ev"]},
             driven_measure="|s12|/s22")
    assert oracle.check_run(write_run(tmp_path, rows, summary, deck)) == []
    return rows, summary, deck


@pytest.mark.parametrize("kind", ["top_level_peak", "record_value", "record_at", "e1_at_peak", "peak_state"])
def test_shear_peak_keys_on_the_measures_row(tmp_path, kind):
    """A shear test's peak is its driven measure's: the top-level peak_ratio13 is null, and the record's peak value,
    its g_at_peak and the test's e1_at_peak and peak_state are the row of the largest |s12|/s22."""
    rows, summary, deck = simple_shear_run(tmp_path)
    t = summary["tests"]["t"]
    words = {"top_level_peak": "top-level peak_ratio13", "record_value": "shear.peak_tau_over_sigma_n",
             "record_at": "shear.g_at_peak", "e1_at_peak": "e1_at_peak", "peak_state": "peak_state.p"}[kind]
    if kind == "top_level_peak":
        t["peak_ratio13"] = max(r["ratio13"] for r in rows)  # the largest s11/s33: not the shear's peak
    elif kind == "record_value":
        t["shear"]["peak_tau_over_sigma_n"] *= 1.001
    elif kind == "record_at":
        t["shear"]["g_at_peak"] += 1e-4
    elif kind == "e1_at_peak":
        t["e1_at_peak"] = max(r["e1"] for r in rows) + 1e-3
    else:
        t["peak_state"]["p"] = rows[-1]["p"]  # the last row's
    problems = oracle.check_run(write_run(tmp_path, rows, summary, deck))
    assert len(problems) == 1 and words in problems[0], problems


def test_extension_peak_is_s33_over_s11(tmp_path):
    """An extension's peak is s33/s11's, in its `extension` record; a null top-level peak_ratio13 is right."""
    rows = triaxial_rows()
    for i, r in enumerate(rows):
        r["e1"], r["e2"], r["e3"] = -r["e1"], -r["e2"], -r["e3"]
        r["s11"] = 1e5 * (1 - 0.6 * math.sin(math.pi * i / (len(rows) - 1) * 0.75))
        r["ratio13"] = r["s11"] / r["s33"]
        r["p"] = (r["s11"] + r["s22"] + r["s33"]) / 3
    deck = copy.deepcopy(DECK)
    deck["tests"][0]["axes"]["x1"]["strain_increment"] = -1e-5
    deck["tests"][0]["end"]["strain"] = -0.03
    summary = true_summary(rows)
    t = summary["tests"]["t"]
    top = max(range(len(rows)), key=lambda i: rows[i]["s33"] / rows[i]["s11"])
    t.update(peak_ratio13=None, peak_reached=True, e1_at_peak=rows[top]["e1"], driven_measure="s33/s11",
             extension={"peak_reached": True, "peak_ratio31": rows[top]["s33"] / rows[top]["s11"],
                        "e1_at_peak": rows[top]["e1"]})
    assert oracle.check_run(write_run(tmp_path, rows, summary, deck)) == []
    t["extension"]["e1_at_peak"] = rows[-1]["e1"]
    problems = oracle.check_run(write_run(tmp_path, rows, summary, deck))
    assert len(problems) == 1 and "extension.e1_at_peak" in problems[0], problems
