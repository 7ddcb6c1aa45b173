#!/usr/bin/python3
"""Cross-code verification: celldem against LAMMPS and LIGGGHTS on the same prepared state.

usage: run_crosscheck.py DECK [--state FILE] [--codes lammps,liggghts] [--np 1] --out DIR [options]

For each target code this
  1. derives a deck from DECK that matches the code's contact model (initial_state = the state,
     "kinematics": "lammps", "tangential_rotation": "project", "moment_arm": "radius" for LAMMPS or
     "contact_point" for LIGGGHTS, and damping.rotational 0 for LIGGGHTS, which has no rotational damping),
  2. runs celldem on it, translates it with `celldem translate` (warnings kept in DIR/<code>/warnings.txt),
  3. runs the code on the translated scripts (mpirun -np N when --np > 1),
  4. compares s11, s22, s33, ev and Z against e1.
Two kinds of scene:
  (a) fully strain-controlled ("strain", added unless --strain-end 0): x1 strained like the deck's first test,
      x2 and x3 by --strain-lateral times as much (default -0.5: a constant-volume shear). Pass: relative
      stress difference < --tol-stress (1e-3) for every row up to e1 = --hold-e1 (0.2 % for LAMMPS, 0.1 % for
      LIGGGHTS, whose dynamics without rotational damping are chaotic; "lammps=X,liggghts=Y" or one value).
  (b) mixed control (the deck's tests, TTC/PSC-like): peak s11/s33 within --tol-peak (relative); e1 at the
      peak (the centre of the strain range where s11/s33 is within 1 % of its peak) within --tol-e1-peak;
      ev at e1 = --at-e1 (or the last common e1) within --tol-ev; Z averaged over e1 in [0.8, 1] x that e1
      within --tol-z. Ratios use the stresses each code actually held (its own s33, servo lag included).
--variants affine,rotate,contact_point,no_rotational_damping,native adds celldem runs with one model choice
changed from the LAMMPS-matched deck (or the deck's own settings), to measure how much each choice matters.
Writes DIR/report.md, DIR/report.json and one overlay plot DIR/<test>.png per test; exit code 1 when a
check fails. Tolerances and the measured differences are discussed in crosscheck/README.md.
"""
import argparse
import copy
import json
import math
import os
import shutil
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
EXE = {"lammps": "lmp", "liggghts": "liggghts"}
COLUMNS = ("e1", "e2", "e3", "ev", "s11", "s22", "s33", "Z", "n_contacts", "kinetic_energy")


# ---- decks ---------------------------------------------------------------------------------------------

def read_deck(path):
    with open(path) as f:
        return json.load(f)


def resolve_state(deck_path, deck, state):
    if state:
        return os.path.abspath(state)
    if "initial_state" in deck:
        return os.path.abspath(os.path.join(os.path.dirname(deck_path), deck["initial_state"]))
    sys.exit("run_crosscheck: the deck has no initial_state; give the prepared state with --state FILE "
             "(e.g. RUN/prepared.state)")


def scene_tests(deck, args):
    """The deck's tests (kind b, or a if all axes are strain-controlled) plus the strain scene (kind a)."""
    tests = [copy.deepcopy(t) for t in deck.get("tests", [])]
    if args.tests:
        keep = args.tests.split(",")
        tests = [t for t in tests if t["name"] in keep]
    for t in tests:
        if args.end_strain:
            t["end"]["strain"] = math.copysign(args.end_strain, t["end"]["strain"])
            t["end"].pop("max_steps", None)
        if args.output_interval:
            t["output_interval"] = args.output_interval
    if args.strain_end > 0 and deck.get("tests"):
        first = deck["tests"][0]
        end_axis = first.get("end", {}).get("axis", "x1")
        driver = first["axes"][end_axis]
        per_step = driver.get("strain_increment", driver.get("strain_rate", 0.0) * deck["time_step"])
        axes = {a: {"strain_increment": args.strain_lateral * per_step} for a in ("x1", "x2", "x3")}
        axes[end_axis] = {"strain_increment": per_step}
        steps = int(round(args.strain_end / abs(per_step)))
        name = "strain" if all(t["name"] != "strain" for t in tests) else "strain_scene"
        tests.insert(0, {"name": name, "friction": first["friction"], "axes": axes,
                         "end": {"axis": end_axis, "strain": math.copysign(args.strain_end, per_step)},
                         "output_interval": max(1, steps // 250)})
    return tests


def derived_deck(deck, state, tests, code, variant=None):
    """The deck matched to `code`'s contact model, or with one model choice changed (VARIANTS), or the
    deck's own settings (variant "native"), all starting from `state`."""
    d = copy.deepcopy(deck)
    d.pop("prepare", None)
    d["initial_state"] = state
    d["tests"] = tests
    what = "native settings" if variant == "native" else "matched to %s%s" % (code, ", variant " + variant if variant else "")
    d["description"] = "run_crosscheck: %s, derived from: %s" % (what, deck.get("description", "the deck"))
    if variant != "native":
        d["kinematics"] = "lammps"
        d["contact"]["tangential_rotation"] = "project"
        d["contact"]["moment_arm"] = "radius" if code == "lammps" else "contact_point"
        if code == "liggghts":
            d["damping"]["rotational"] = 0.0
        if variant:
            section, key, value = VARIANTS[variant]
            (d[section] if section else d)[key] = value
    return d


# One model choice changed from the LAMMPS-matched deck: name -> (section, key, value).
VARIANTS = {
    "affine": (None, "kinematics", "affine"),                     # contacts see the affine velocity difference
    "rotate": ("contact", "tangential_rotation", "rotate"),       # spring length kept when the plane turns
    "contact_point": ("contact", "moment_arm", "contact_point"),  # lever arm r - overlap/2
    "no_rotational_damping": ("damping", "rotational", 0.0),
}


# ---- running -------------------------------------------------------------------------------------------

def sh(cmd, cwd=None, log=None, env=None):
    t0 = time.time()
    with open(log, "w") if log else open(os.devnull, "w") as out:
        r = subprocess.run(cmd, cwd=cwd, stdout=out, stderr=subprocess.STDOUT, env=env)
    if r.returncode != 0:
        sys.exit("run_crosscheck: failed (%d): %s%s" % (r.returncode, " ".join(cmd), " (see %s)" % log if log else ""))
    return time.time() - t0


def mpi_env():
    env = dict(os.environ)
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # Open MPI refuses root unless told
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    return env


def run_celldem(args, deck, folder):
    os.makedirs(folder, exist_ok=True)
    deck_path = os.path.join(folder, "deck.json")
    run_dir = os.path.join(folder, "celldem")
    done = os.path.join(run_dir, "summary.json")
    if args.reuse and os.path.exists(done) and same_json(deck_path, deck):
        summary = json.load(open(done))
        if all(t["name"] in summary.get("tests", {}) for t in deck["tests"]):
            return run_dir, None
    with open(deck_path, "w") as f:
        json.dump(deck, f, indent=2)
    cmd = [args.celldem, "run", deck_path, "--out", run_dir, "--force", "--quiet"]
    if args.threads:
        cmd += ["--threads", str(args.threads)]
    wall = sh(cmd, log=os.path.join(folder, "celldem.log"))
    return run_dir, wall


def same_json(path, obj):
    try:
        return json.load(open(path)) == obj
    except (OSError, ValueError):
        return False


def translate(args, folder, code):
    out = os.path.join(folder, code)
    r = subprocess.run([args.celldem, "translate", os.path.join(folder, "deck.json"), "--to", code, "--out", out,
                        "--force"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("run_crosscheck: celldem translate failed:\n" + r.stderr)
    warnings = [l.split("warning: ", 1)[1] for l in r.stderr.splitlines() if "warning: " in l]
    with open(os.path.join(folder, "warnings.txt"), "w") as f:
        f.write("\n".join(warnings) + ("\n" if warnings else ""))
    return out, warnings


def run_code(args, code, script_dir, test, np_ranks, tag=""):
    """Runs the translated script of `test`; tag names a second run of the same script (another output)."""
    stem = "%s.%s%s" % (test["name"], code, tag)
    series = os.path.join(script_dir, stem + ".csv")
    if args.reuse and os.path.exists(series) and last_step(series) >= expected_steps(args, test):
        return series, None
    cmd = [EXE[code], "-in", "%s.%s.in" % (test["name"], code), "-var", "out", stem + ".csv", "-log", stem + ".log",
           "-screen", "none"]
    if np_ranks > 1:
        cmd = ["mpirun", "-np", str(np_ranks)] + cmd
    wall = sh(cmd, cwd=script_dir, env=mpi_env())
    return series, wall


def expected_steps(args, test):
    axis = test["end"]["axis"]
    a = test["axes"][axis]
    per = a.get("strain_increment", a.get("strain_rate", 0.0) * args.dt)
    n = int(round(test["end"]["strain"] / per))
    return n - n % test.get("output_interval", 1000)


def count_atoms(data_path):
    with open(data_path) as f:
        for line in f:
            if line.strip().endswith(" atoms"):
                return int(line.split()[0])
    return 0


def last_step(path):
    try:
        with open(path) as f:
            rows = [l for l in f.read().splitlines() if l and l[0].isdigit()]
        return int(rows[-1].split(",")[0]) if rows else -1
    except OSError:
        return -1


# ---- series and comparisons -----------------------------------------------------------------------------

def load_series(path):
    a = np.genfromtxt(path, delimiter=",", names=True)
    return {c: np.atleast_1d(a[c]).astype(float) for c in COLUMNS if c in a.dtype.names}


def kind_of(test):
    return "a" if all("stress" not in ax for ax in test["axes"].values()) else "b"


def on_grid(ref, other, key):
    """other[key] interpolated at ref's e1 (NaN outside other's range)."""
    e_ref, e_o = ref["e1"], other["e1"]
    order = np.argsort(e_o)
    y = np.interp(e_ref, e_o[order], other[key][order])
    y[(e_ref < e_o.min() - 1e-12) | (e_ref > e_o.max() + 1e-12)] = np.nan
    return y


def compare_strain_scene(ref, other, tol, hold):
    """Kind (a): relative stress difference per row against e1; the e1 up to which it stays below tol."""
    rel = np.full(len(ref["e1"]), np.nan)
    for k in ("s11", "s22", "s33"):
        d = np.abs(on_grid(ref, other, k) - ref[k]) / np.abs(ref[k])
        rel = np.fmax(rel, d)
    dz = np.abs(on_grid(ref, other, "Z") - ref["Z"])
    valid = ~np.isnan(rel)
    bad = valid & (rel >= tol)
    e = ref["e1"]
    holds_to = e[valid][-1] if not bad.any() else (e[valid & (e < e[bad][0])].max(initial=0.0))
    in_range = valid & (e <= hold + 1e-12)
    return {"kind": "a", "tolerance": tol, "required_e1": hold, "holds_to_e1": float(holds_to),
            "max_rel_stress_diff_to_required": float(np.nanmax(rel[in_range])) if in_range.any() else None,
            "max_abs_Z_diff_to_required": float(np.nanmax(dz[in_range])) if in_range.any() else None,
            "rel_stress_diff_at_end": float(rel[valid][-1]), "final_e1": float(e[valid][-1]),
            "pass": bool(holds_to >= hold - 1e-12),
            "curve": {"e1": e.tolist(), "rel": rel.tolist()}}


def window_mean(s, key, e1, width=0.2):
    """Mean of s[key] over the rows with e1 in [(1 - width) e1, e1]: Z of a small sample jumps by whole contacts."""
    rows = (s["e1"] >= (1.0 - width) * e1 - 1e-12) & (s["e1"] <= e1 + 1e-12)
    return float(s[key][rows].mean()) if rows.any() else float(np.interp(e1, s["e1"], s[key]))


def mixed_metrics(s, at_e1, targets):
    ratio = s["s11"] / s["s33"]
    k = int(np.nanargmax(ratio))
    e1 = min(at_e1, float(s["e1"].max()))
    # The peak is flat (within 1 % over 1-2 % of strain at full scale), so where its maximum falls is noise;
    # the centre of the range where the ratio stays within 1 % of the peak is a stable "e1 at peak".
    near = s["e1"][ratio >= 0.99 * ratio[k]]
    out = {"peak_ratio13": float(ratio[k]), "e1_at_max": float(s["e1"][k]),
           "e1_at_peak": float(0.5 * (near.min() + near.max())), "peak_range": [float(near.min()), float(near.max())],
           "at_e1": e1,
           "ev_at": float(np.interp(e1, s["e1"], s["ev"])), "Z_at": window_mean(s, "Z", e1),
           "ratio_at": float(np.interp(e1, s["e1"], ratio))}
    for key, target in targets.items():  # servo lag over the second half of the test
        half = s["e1"] >= 0.5 * s["e1"].max()
        lag = s[key][half] - target
        out["lag_" + key] = [float(lag.mean()), float(lag.std())]
    return out


def compare(ref, other, test, args, code):
    return (compare_strain_scene(ref, other, args.tol_stress, args.hold_e1[code]) if kind_of(test) == "a"
            else compare_mixed(ref, other, test, args))


def compare_mixed(ref, other, test, args):
    targets = {"s%d%d" % (i, i): ax["stress"] for i, ax in
               ((int(a[1]), v) for a, v in test["axes"].items()) if "stress" in ax}
    e_common = min(float(ref["e1"].max()), float(other["e1"].max()))
    at = min(args.at_e1, e_common)
    a, b = mixed_metrics(ref, at, targets), mixed_metrics(other, at, targets)
    ratio_o = on_grid(ref, other, "s11") / on_grid(ref, other, "s33")
    rr = np.abs(ratio_o / (ref["s11"] / ref["s33"]) - 1.0)
    checks = {
        "peak_ratio13": (abs(b["peak_ratio13"] / a["peak_ratio13"] - 1.0), args.tol_peak, "relative"),
        "e1_at_peak": (abs(b["e1_at_peak"] - a["e1_at_peak"]), args.tol_e1_peak, "absolute"),
        "ev_at": (abs(b["ev_at"] - a["ev_at"]), args.tol_ev, "absolute"),
        "Z_at": (abs(b["Z_at"] - a["Z_at"]), args.tol_z, "absolute"),
    }
    return {"kind": "b", "celldem": a, "code": b, "at_e1": at,
            "checks": {k: {"diff": float(d), "tolerance": t, "how": how, "pass": bool(d <= t)}
                       for k, (d, t, how) in checks.items()},
            "ratio13_rel_diff_max": float(np.nanmax(rr)), "ratio13_rel_diff_rms": float(np.sqrt(np.nanmean(rr ** 2))),
            "pass": all(d <= t for d, t, _ in checks.values())}


# ---- plots and report ------------------------------------------------------------------------------------

def plot_test(path, test, curves, comparisons):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    kind = kind_of(test)
    fig, ax = plt.subplots(2, 3, figsize=(15, 8))
    panels = [("s11", "s11 [kPa]", 1e-3), ("s22", "s22 [kPa]", 1e-3), ("s33", "s33 [kPa]", 1e-3),
              ("ev", "ev [%]", 100), ("Z", "Z", 1)]
    for (key, label, scale), a in zip(panels, ax.flat):
        for name, s in curves.items():
            a.plot(100 * s["e1"], scale * s[key], label=name, lw=1)
        a.set_xlabel("e1 [%]")
        a.set_ylabel(label)
        a.grid(alpha=0.3)
    a = ax.flat[5]
    if kind == "a":
        for name, c in comparisons.items():
            a.semilogy(100 * np.array(c["curve"]["e1"]), np.array(c["curve"]["rel"]), label=name)
        a.axhline(comparisons[next(iter(comparisons))]["tolerance"] if comparisons else 1e-3, color="k", ls=":")
        a.set_ylabel("max relative stress difference to celldem")
    else:
        for name, s in curves.items():
            a.plot(100 * s["e1"], s["s11"] / s["s33"], label=name, lw=1)
        a.set_ylabel("s11/s33 (stresses held)")
    a.set_xlabel("e1 [%]")
    a.grid(alpha=0.3)
    ax.flat[0].legend(fontsize=8)
    fig.suptitle("%s (kind %s): celldem versus the target codes on the same state" % (test["name"], kind))
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def fmt(x, spec=".4g"):
    return "—" if x is None else format(x, spec)


def verdict(ok, comparison):
    return "(noise, no check)" if comparison.get("informational") else ("pass" if ok else "**FAIL**")


def write_report(out, report):
    lines = ["# celldem cross-check", "",
             "Deck `%s`, state `%s`, %d particles; codes %s, %d MPI rank(s)." %
             (report["deck"], report["state"], report["particles"], ", ".join(report["codes"]), report["np"]), ""]
    for test in report["tests"]:
        lines += ["## %s (kind %s)" % (test["name"], test["kind"]), "", "![%s](%s.png)" % (test["name"], test["name"]), ""]
        if test["kind"] == "a":
            lines += ["| pair | holds to e1 | required | max rel. stress diff to required | max dZ to required | "
                      "rel. diff at end (e1) | pass |", "|---|---|---|---|---|---|---|"]
            for name, c in test["comparisons"].items():
                lines.append("| %s | %s %% | %s %% (tol %s) | %s | %s | %s (%s %%) | %s |" % (
                    name, fmt(100 * c["holds_to_e1"], ".3g"), fmt(100 * c["required_e1"], ".3g"), fmt(c["tolerance"], ".0e"),
                    fmt(c["max_rel_stress_diff_to_required"], ".2e"), fmt(c["max_abs_Z_diff_to_required"], ".3f"),
                    fmt(c["rel_stress_diff_at_end"], ".2e"), fmt(100 * c["final_e1"], ".3g"),
                    verdict(c["pass"], c)))
        else:
            lines += ["| pair | quantity | celldem | code | difference | tolerance | pass |", "|---|---|---|---|---|---|---|"]
            for name, c in test["comparisons"].items():
                for key, chk in c["checks"].items():
                    label = {"peak_ratio13": "peak s11/s33", "e1_at_peak": "e1 at peak (centre of ≥ 99 % of peak)",
                             "ev_at": "ev at e1 = %.3g %%" % (100 * c["at_e1"]),
                             "Z_at": "Z (mean over e1 %.3g–%.3g %%)" % (80 * c["at_e1"], 100 * c["at_e1"])}[key]
                    lines.append("| %s | %s | %s | %s | %s | %s (%s) | %s |" % (
                        name, label, fmt(c["celldem"][key]), fmt(c["code"][key]), fmt(chk["diff"], ".3g"),
                        fmt(chk["tolerance"], ".3g"), chk["how"], verdict(chk["pass"], c)))
                lines.append("| %s | e1 at the maximum; range within 1 %% of it | %s; %s–%s | %s; %s–%s | | | |" % (
                    name, fmt(c["celldem"]["e1_at_max"]), fmt(c["celldem"]["peak_range"][0]),
                    fmt(c["celldem"]["peak_range"][1]), fmt(c["code"]["e1_at_max"]), fmt(c["code"]["peak_range"][0]),
                    fmt(c["code"]["peak_range"][1])))
                lags = ", ".join("%s %+.0f ± %.0f Pa (celldem %+.0f)" % (k[4:], v[0], v[1], c["celldem"][k][0])
                                 for k, v in c["code"].items() if k.startswith("lag_"))
                lines.append("| %s | servo lag (2nd half) | | %s | | | |" % (name, lags))
                lines.append("| %s | s11/s33 curve, rel. diff max / rms | | | %.3g / %.3g | | |" %
                             (name, c["ratio13_rel_diff_max"], c["ratio13_rel_diff_rms"]))
        if test.get("variants"):
            lines += ["", "celldem model variants against the LAMMPS-matched celldem run (same state):", "",
                      "| variant | quantity | value | matched | difference |", "|---|---|---|---|---|"]
            for name, v in test["variants"].items():
                for key, (val, ref) in v.items():
                    lines.append("| %s | %s | %s | %s | %s |" % (name, key, fmt(val), fmt(ref), fmt(val - ref, ".3g")))
        lines.append("")
    lines += ["## Warnings from `celldem translate` (matched decks)", ""]
    for code, ws in report["warnings"].items():
        lines += ["- %s: %s" % (code, w) for w in ws] or ["- %s: none" % code]
    lines += ["", "## Wall times [s]", ""] + ["- %s: %s" % (k, fmt(v, ".1f")) for k, v in report["wall"].items()]
    lines += ["", "Overall: **%s**" % ("pass" if report["pass"] else "FAIL"), ""]
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines))


def variant_metrics(series, test, at_e1):
    if kind_of(test) == "a":
        return {"s11 at end": float(series["s11"][-1]), "s22 at end": float(series["s22"][-1]),
                "Z at end": float(series["Z"][-1])}
    m = mixed_metrics(series, at_e1, {})
    return {"peak s11/s33": m["peak_ratio13"], "e1 at peak": m["e1_at_peak"],
            "ev at e1 = %.3g %%" % (100 * m["at_e1"]): m["ev_at"], "Z (mean over e1 %.3g–%.3g %%)" % (80 * m["at_e1"], 100 * m["at_e1"]): m["Z_at"]}


# ---- main ------------------------------------------------------------------------------------------------

def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[1], formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__)
    p.add_argument("deck")
    p.add_argument("--state", help="prepared state (default: the deck's initial_state)")
    p.add_argument("--codes", default="lammps,liggghts")
    p.add_argument("--np", type=int, default=1, help="MPI ranks for the target codes")
    p.add_argument("--out", required=True)
    p.add_argument("--celldem", default=None, help="celldem binary (default: ROOT/build/celldem, else PATH)")
    p.add_argument("--threads", type=int, default=0, help="celldem threads (default: OpenMP default)")
    p.add_argument("--tests", help="comma-separated subset of the deck's tests")
    p.add_argument("--end-strain", type=float, default=0.0, help="override the end strain of the deck's tests")
    p.add_argument("--output-interval", type=int, default=0, help="override the deck's output intervals")
    p.add_argument("--strain-end", type=float, default=0.005, help="e1 of the strain-controlled scene (0: none)")
    p.add_argument("--strain-lateral", type=float, default=-0.5,
                   help="strain scene: lateral increment / axial increment (-0.5: constant volume, 0: oedometric)")
    p.add_argument("--variants", default="",
                   help="extra celldem runs, each with one choice changed from the LAMMPS-matched deck: "
                        "affine, rotate, contact_point, no_rotational_damping; or native (the deck's own settings)")
    p.add_argument("--noise", action="store_true",
                   help="also run each code on another rank count and report that difference (not a check)")
    p.add_argument("--reuse", action="store_true", help="keep runs already complete in --out")
    p.add_argument("--tol-stress", type=float, default=1e-3)
    p.add_argument("--hold-e1", default="lammps=0.002,liggghts=0.001",
                   help="e1 up to which kind (a) must hold --tol-stress: one value or lammps=X,liggghts=Y")
    p.add_argument("--tol-peak", type=float, default=0.03)
    p.add_argument("--tol-e1-peak", type=float, default=0.01)
    p.add_argument("--at-e1", type=float, default=0.05)
    p.add_argument("--tol-ev", type=float, default=1e-3)
    p.add_argument("--tol-z", type=float, default=0.05)
    args = p.parse_args(argv)
    if "=" in args.hold_e1:
        args.hold_e1 = {k: float(v) for k, v in (kv.split("=") for kv in args.hold_e1.split(","))}
    else:
        args.hold_e1 = {code: float(args.hold_e1) for code in EXE}
    if args.celldem is None:
        built = os.path.join(ROOT, "build", "celldem")
        args.celldem = built if os.path.exists(built) else (shutil.which("celldem") or built)
    return args


def main(argv=None):
    args = parse_args(argv)
    deck = read_deck(args.deck)
    args.dt = deck["time_step"]
    state = resolve_state(args.deck, deck, args.state)
    if not os.path.exists(state):
        sys.exit("run_crosscheck: no state file %s" % state)
    codes = [c for c in args.codes.split(",") if c]
    for c in codes:
        if c not in EXE:
            sys.exit("run_crosscheck: unknown code %s" % c)
        if not shutil.which(EXE[c]):
            sys.exit("run_crosscheck: %s not found (tools/install-deps.sh --with-crosscheck installs it)" % EXE[c])
    os.makedirs(args.out, exist_ok=True)
    tests = scene_tests(deck, args)
    report = {"deck": args.deck, "state": state, "codes": codes, "np": args.np, "tests": [], "warnings": {},
              "wall": {}, "particles": 0}

    runs = {}  # name -> (celldem run dir, code series dir or None, code)
    for code in codes:
        folder = os.path.join(args.out, code)
        d = derived_deck(deck, state, tests, code)
        run_dir, wall = run_celldem(args, d, folder)
        report["wall"]["celldem (%s-matched)" % code] = wall
        script_dir, warnings = translate(args, folder, code)
        report["warnings"][code] = warnings
        runs[code] = (run_dir, script_dir, code)
    for v in [v for v in args.variants.split(",") if v]:
        folder = os.path.join(args.out, "variant-" + v)
        if v not in VARIANTS and v != "native":
            sys.exit("run_crosscheck: unknown variant %s (known: native, %s)" % (v, ", ".join(VARIANTS)))
        d = derived_deck(deck, state, tests, "lammps", variant=v)
        run_dir, wall = run_celldem(args, d, folder)
        report["wall"]["celldem (%s)" % v] = wall
        runs["variant-" + v] = (run_dir, None, None)

    ok = True
    for test in tests:
        name, kind = test["name"], kind_of(test)
        curves, comps, variants = {}, {}, {}
        for code in codes:
            run_dir, script_dir, _ = runs[code]
            ref = load_series(os.path.join(run_dir, name, "series.csv"))
            series, wall = run_code(args, code, script_dir, test, args.np)
            report["wall"]["%s %s (np %d)" % (code, name, args.np)] = wall
            other = load_series(series)
            curves["celldem (%s-matched)" % code] = ref
            curves[code] = other
            comps["celldem vs " + code] = compare(ref, other, test, args, code)
            ok &= comps["celldem vs " + code]["pass"]
            if args.noise:  # the same script on another rank count: round-off only, amplified by the dynamics
                other_np = 2 if args.np == 1 else 1
                series2, wall = run_code(args, code, script_dir, test, other_np, tag=".np%d" % other_np)
                report["wall"]["%s %s (np %d)" % (code, name, other_np)] = wall
                noise = compare(other, load_series(series2), test, args, code)
                noise["informational"] = True
                comps["%s np%d vs np%d (noise floor)" % (code, args.np, other_np)] = noise
        base = load_series(os.path.join(runs[codes[0]][0], name, "series.csv")) if codes else None
        for key, (run_dir, _, _) in runs.items():
            if key.startswith("variant-"):
                s = load_series(os.path.join(run_dir, name, "series.csv"))
                curves["celldem " + key[8:]] = s
                if base is not None:
                    vm, bm = variant_metrics(s, test, args.at_e1), variant_metrics(base, test, args.at_e1)
                    variants[key[8:]] = {k: (vm[k], bm[k]) for k in vm if k in bm}
        plot_test(os.path.join(args.out, name + ".png"), test, curves, comps)
        for c in comps.values():
            c.pop("curve", None)
        report["tests"].append({"name": name, "kind": kind, "comparisons": comps, "variants": variants})
    if codes:
        report["particles"] = count_atoms(os.path.join(runs[codes[0]][1], "state.data"))
    report["pass"] = bool(ok)
    with open(os.path.join(args.out, "report.json"), "w") as f:
        json.dump(report, f, indent=2)
    write_report(args.out, report)
    print("run_crosscheck: %s; report in %s" % ("pass" if ok else "FAIL", os.path.join(args.out, "report.md")))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
