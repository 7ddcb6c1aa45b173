#!/usr/bin/python3
"""Reduced cross-check of a translated load program against LAMMPS (ctest: crosscheck_program).

Self-contained: prepares the 300-sphere state of small.json with celldem (as reduced_crosscheck.py does), then
runs one two-leg test in celldem and, translated by `celldem translate`, in LAMMPS, both on that state with the
deck matched to LAMMPS's contact model (tools/celldem/crosscheck.py's derived_deck):

  leg 1: x1 compressed at 2e-7 per step to e1 = 0.3 % (15 000 steps), x2 on b = 0.5, x3 on p = 100 kPa
         (Thornton's constant-b, constant-p path: the b axis and the mean-stress axis servo-controlled to
         targets computed each step from the stresses);
  leg 2: x1 unloaded at -2e-7 per step, same b and p, until s11/s33 = 1.2 (max_steps 30 000): an end that only
         running tells, fix halt in LAMMPS.

Checks (tolerances from the known model differences, crosscheck/README.md "Load programs", set about 30 %
above the largest value measured over 12 realizations of the 300-sphere sample: seeds 1-6 of small.json,
each prepared with two summation orders of the net forces; a 300-sphere sample is noisy from one
realization to the next, LIGGGHTS's the most, as it lacks the rotational body damping):
  - leg lengths: leg 1 runs exactly celldem's leg_steps (15 000) in both codes;
  - the end of leg 2: e1 where s11/s33 reached 1.2, within 1.5e-4 (absolute strain; measured up to 9.8e-5).
    LAMMPS's proportional servo trails the moving targets by about K * (lateral strain per step) / gain
    (~1 kPa on s33 while unloading), which shifts s11/s33 by ~1 % and the end by ~1e-5-1e-4 of strain;
  - the controls as each code held them, over each leg after its first 0.05 % of strain: celldem (PI servo)
    |b - 0.5| < 0.012 and |p/p* - 1| < 2e-3 (measured up to 0.009 and 4.4e-4); LAMMPS and LIGGGHTS
    (proportional, nominal stiffness, no integral term) |b - 0.5| < 0.09 and |p/p* - 1| < 1.5e-2 (measured
    up to 0.068 and 0.006);
  - the macro curves against e1 in each leg (the other code interpolated at celldem's e1): s11/s33 within
    8.5 % relative (measured up to 6.6 %, median 2 %), s11, s22, s33 within 5 % of p (servo lag; measured up
    to 3.7 %, median 1.8 %), e2, e3 and ev within 3.5e-4 absolute (measured up to 2.6e-4, median 8e-5).
Prints a table of the measured values and exits 1 when a check fails, 77 (ctest: skipped) without lmp.

usage: program_crosscheck.py --celldem BIN [--work DIR]
"""
import copy
import json
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
from celldem import crosscheck, results

import xc_common  # noqa: E402

DECK = os.path.join(HERE, "small.json")
P = 1.0e5       # mean stress held in both legs [Pa]
B = 0.5         # b held in both legs
D = 2.0e-7      # strain increment of x1 per step
E1_TURN = 0.003
RATIO_END = 1.2
SETTLE = 5e-4   # strain after a leg's start before its controls are checked (the servo's transient)

TEST = {"name": "bp", "friction": 0.5, "output_interval": 100, "legs": [
    {"axes": {"x1": {"strain_increment": D}, "x2": {"b": B}, "x3": {"mean_stress": P}},
     "end": {"axis": "x1", "strain": E1_TURN}},
    {"axes": {"x1": {"strain_increment": -D}, "x2": {"b": B}, "x3": {"mean_stress": P}},
     "end": {"ratio": RATIO_END, "max_steps": 30000}}]}

TOL = {
    "b_celldem": 1.2e-2, "p_celldem": 2e-3,  # celldem's own control (PI servo)
    # e1_end: absolute strain; b: |b - 0.5|; p: |p/p* - 1|; ratio: relative; stress: of p; strain: absolute
    "lammps": {"e1_end": 1.5e-4, "b": 9e-2, "p": 1.5e-2, "ratio": 0.085, "stress": 0.05, "strain": 3.5e-4},
    # LIGGGHTS: no rotational body damping (chaotic, see crosscheck/README.md) and ends checked every 100 steps
    "liggghts": {"e1_end": 1.5e-4, "b": 9e-2, "p": 1.5e-2, "ratio": 0.085, "stress": 0.05, "strain": 3.5e-4},
}


def prepare(celldem, work):
    with open(DECK) as f:
        return xc_common.prepare_state(celldem, work, json.load(f))


def with_derived(series):
    s = dict(series)
    s["p"] = (s["s11"] + s["s22"] + s["s33"]) / 3.0
    with np.errstate(divide="ignore", invalid="ignore"):
        s["b"] = (s["s22"] - s["s33"]) / (s["s11"] - s["s33"])
        s["ratio"] = s["s11"] / s["s33"]
    return s


def rows(s, mask):
    return {k: v[mask] for k, v in s.items()}


def legs_of_code(s):
    """The rows of each leg: leg 1 up to its last step (LAMMPS prints the row of step 15000 twice: at the end of
    leg 1's run and at the start of leg 2's, with the same values), leg 2 after it."""
    _, first = np.unique(s["step"], return_index=True)
    s = rows(s, np.sort(first))
    turn = int(round(E1_TURN / D))
    return rows(s, s["step"] <= turn), rows(s, s["step"] > turn)


def compare_leg(name, ref, other, start):
    """Max differences of `other` against `ref` at ref's e1 (after SETTLE of strain from the leg start)."""
    order = np.argsort(other["e1"])
    x = other["e1"][order]
    keep = (np.abs(ref["e1"] - start) >= SETTLE) & (ref["e1"] >= x[0]) & (ref["e1"] <= x[-1])
    e1 = ref["e1"][keep]
    at = {k: np.interp(e1, x, other[k][order]) for k in ("s11", "s22", "s33", "e2", "e3", "ev", "ratio", "p", "b")}
    own = {k: ref[k][keep] for k in at}
    return {
        "leg": name, "rows": int(keep.sum()),
        "ratio": float(np.max(np.abs(at["ratio"] / own["ratio"] - 1.0))),
        "stress": float(max(np.max(np.abs(at[k] - own[k])) for k in ("s11", "s22", "s33")) / P),
        "strain": float(max(np.max(np.abs(at[k] - own[k])) for k in ("e2", "e3", "ev"))),
    }


def held(s, start):
    keep = np.abs(s["e1"] - start) >= SETTLE
    return float(np.max(np.abs(s["b"][keep] - B))), float(np.max(np.abs(s["p"][keep] / P - 1.0)))


def code_checks(celldem, work, state, code):
    """Runs the program in celldem (deck matched to `code`) and in `code`; returns the checks and the warnings."""
    name = "LAMMPS" if code == "lammps" else "LIGGGHTS"
    deck = crosscheck.derived_deck(json.load(open(DECK)), state, [copy.deepcopy(TEST)], code)
    folder = os.path.join(work, code)
    os.makedirs(folder)
    deck_path = os.path.join(folder, "program.json")
    json.dump(deck, open(deck_path, "w"), indent=2)
    subprocess.run([celldem, "run", deck_path, "--out", os.path.join(folder, "celldem"), "--threads", "1", "--quiet"],
                   check=True)
    tr = subprocess.run([celldem, "translate", deck_path, "--to", code, "--out", folder],
                        check=True, capture_output=True, text=True)
    warnings = [w for w in tr.stderr.splitlines() if "warning" in w]
    exe = "lmp" if code == "lammps" else "liggghts"
    subprocess.run([exe, "-in", "bp.%s.in" % code, "-log", "log.%s" % code, "-screen", "none"], cwd=folder, check=True)
    log = open(os.path.join(folder, "log.%s" % code)).read()

    ref = with_derived(results.load_series(os.path.join(folder, "celldem", "bp", "series.csv")))
    other = with_derived(results.load_series(os.path.join(folder, "bp.%s.csv" % code)))
    tol = TOL[code]
    checks = []  # (what, celldem, code, measured difference, tolerance)

    # Leg lengths. celldem: the last row of leg 0 (15000 is an output step); the code: its first run.
    expected = int(round(E1_TURN / D))
    n1_ref = int(ref["step"][ref["leg"] == 0][-1])
    loops = [int(n) for n in re.findall(r"Loop time of \S+ on \d+ procs for (\d+) steps", log)]
    n1_other = loops[0] if loops else -1
    checks.append(("leg 1 steps (celldem's leg_steps: %d)" % expected, n1_ref, n1_other,
                   max(abs(n1_ref - expected), abs(n1_other - expected)), 0))

    # The end of leg 2: celldem's last row is its end; LAMMPS's fix halt names the step, LIGGGHTS's last chunk
    # ends it (up to 99 steps late). Strain path of x1 as celldem's: e1 = 0.3 % - (steps of leg 2) d.
    if code == "lammps":
        halt = re.search(r"Fix halt condition for fix-id hlt met on step (\d+)", log)
        last = int(halt.group(1)) if halt else -1
    else:
        last = sum(loops)
    e1_end_ref = float(ref["e1"][-1])
    e1_end_other = E1_TURN - (last - expected) * D if last > 0 else float("nan")
    checks.append(("leg 2 end: e1 at s11/s33 = %g" % RATIO_END, e1_end_ref, e1_end_other,
                   abs(e1_end_ref - e1_end_other), tol["e1_end"]))

    # The controls as each code held them, and the curves.
    ref1, ref2 = rows(ref, ref["leg"] == 0), rows(ref, ref["leg"] == 1)
    other1, other2 = legs_of_code(other)
    for leg, r, o, start in (("leg 1", ref1, other1, 0.0), ("leg 2", ref2, other2, E1_TURN)):
        b_ref, p_ref = held(r, start)
        b_other, p_other = held(o, start)
        checks.append(("%s celldem: max |b - %g|, max |p/p* - 1|" % (leg, B), b_ref, p_ref,
                       max(b_ref / TOL["b_celldem"], p_ref / TOL["p_celldem"]), 1.0))
        checks.append(("%s %s: max |b - %g|, max |p/p* - 1|" % (leg, name, B), b_other, p_other,
                       max(b_other / tol["b"], p_other / tol["p"]), 1.0))
        c = compare_leg(leg, r, o, start)
        checks.append(("%s s11/s33 at equal e1 (%d rows), rel." % (leg, c["rows"]), None, None, c["ratio"], tol["ratio"]))
        checks.append(("%s s11, s22, s33 at equal e1, / p" % leg, None, None, c["stress"], tol["stress"]))
        checks.append(("%s e2, e3, ev at equal e1, abs." % leg, None, None, c["strain"], tol["strain"]))
    return checks, warnings


def run(celldem, work, codes):
    state = prepare(celldem, work)
    ok = True
    for code in codes:
        checks, warnings = code_checks(celldem, work, state, code)
        name = "LAMMPS" if code == "lammps" else "LIGGGHTS"
        print("\ncelldem vs %s, load program (b = %g, p = %g Pa: load to e1 = %g, unload to s11/s33 = %g)"
              % (name, B, P, E1_TURN, RATIO_END))
        print("%-58s %14s %14s %11s %9s  %s" % ("check", "celldem", name, "measured", "tolerance", ""))
        for what, a, b, diff, tol in checks:
            good = diff <= tol
            ok = ok and good
            fmt = lambda v: "" if v is None else ("%d" % v if isinstance(v, int) else "%.6g" % v)  # noqa: E731
            print("%-58s %14s %14s %11.3g %9.3g  %s" % (what, fmt(a), fmt(b), diff, tol, "pass" if good else "FAIL"))
        print("(controls: the measured column is the larger of the two errors over its tolerance, tolerance 1)")
        print("translator warnings (model differences):")
        for w in warnings:
            print("  " + w)
    return 0 if ok else 1


def main():
    return xc_common.main_for_codes("celldem-program-xc-", run)


if __name__ == "__main__":
    sys.exit(main())
