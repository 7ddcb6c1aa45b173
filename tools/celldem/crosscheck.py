"""Cross-code verification, celldem against LAMMPS and LIGGGHTS on the same prepared state
(crosscheck/run_crosscheck.py; its docstring describes the checks, crosscheck/README.md the measured differences).

celldem's side of each comparison is its summary.json; the other code's series has none, so its quantities come
from `celldem summarize`, which applies summary.json's definitions (solver/run/summary.cpp) to any series. Steps, strain per step and the number
of particles come from `celldem plan`.
"""

import copy
import json
import math
import os
import shutil
import subprocess
import time

import numpy as np

from . import binary
from .reports import plotting
from .metrics import on_grid
from .results import column, load_json, load_series, read_json
from .reports.tables import fmt_spec, md_table

EXE = {"lammps": "lmp", "liggghts": "liggghts"}
STRAIN_SCENE_ROWS = 250   # rows of the strain-controlled scene

# The quantities of a mixed-control test that are compared: summary.json key -> (label, how the tolerance applies).
# ev and Z at the end: the final row's εv, and Z averaged over the end window (Z of a small sample jumps by whole
# contacts from row to row).
MIXED_CHECKS = {
    "peak_ratio13": ("peak s11/s33", "relative"),
    "e1_at_peak_centre": ("e1 at peak (centre of ≥ 99 % of peak)", "absolute"),
    "ev_final": ("ev at the end", "absolute"),
    "end_window.Z": ("Z (mean over the end window)", "absolute"),
}

# One model choice changed from the LAMMPS-matched deck: name -> (section, key, value).
VARIANTS = {
    "affine": (None, "kinematics", "affine"),                     # contacts see the affine velocity difference
    "rotate": ("contact", "tangential_rotation", "rotate"),       # spring length kept when the plane turns
    "contact_point": ("contact", "moment_arm", "contact_point"),  # lever arm r - overlap/2
    "no_rotational_damping": ("damping", "rotational", 0.0),
}


class CrosscheckError(Exception):
    """A cross-check that cannot go on (a missing state or code, a command that failed); the command line
    (crosscheck/run_crosscheck.py) prints it and exits 1."""


def fail(message):
    """Raises CrosscheckError(message): the library never exits, its command line does."""
    raise CrosscheckError(message)


def get(quantities, key):
    """A value of a summary dict by key path ("end_window.Z"); None where missing."""
    value = quantities
    for part in key.split("."):
        value = value.get(part) if isinstance(value, dict) else None
    return value


# ---- decks ---------------------------------------------------------------------------------------------

def resolve_state(deck_path, deck, state):
    if state:
        return os.path.abspath(state)
    if "initial_state" in deck:
        return os.path.abspath(os.path.join(os.path.dirname(deck_path), deck["initial_state"]))
    fail("the deck has no initial_state; give the prepared state with --state FILE (e.g. RUN/prepared.state)")


def scene_tests(deck, deck_plan, args):
    """The deck's tests (kind b, or a if all axes are strain-controlled) plus the strain scene (kind a), and the
    strain scene's name (None without one). Its output interval is a placeholder until its steps are planned
    (set_strain_scene_interval)."""
    tests = [copy.deepcopy(t) for t in deck.get("tests", [])]
    if args.tests:
        keep = args.tests.split(",")
        tests = [t for t in tests if t["name"] in keep]
    end_strain = min(s for s in (args.end_strain, args.at_e1) if s) if (args.end_strain or args.at_e1) else 0.0
    for t in tests:
        if end_strain:
            t["end"]["strain"] = math.copysign(end_strain, t["end"]["strain"])
            t["end"].pop("max_steps", None)
        if args.output_interval:
            t["output_interval"] = args.output_interval
    if args.strain_end > 0 and deck.get("tests"):
        first, first_plan = deck["tests"][0], deck_plan["tests"][0]
        end_axis, per_step = first_plan["end_axis"], first_plan["strain_per_step"]
        axes = {a: {"strain_increment": args.strain_lateral * per_step} for a in ("x1", "x2", "x3")}
        axes[end_axis] = {"strain_increment": per_step}
        name = "strain" if all(t["name"] != "strain" for t in tests) else "strain_scene"
        tests.insert(0, {"name": name, "friction": first["friction"], "axes": axes,
                         "end": {"axis": end_axis, "strain": math.copysign(args.strain_end, per_step)},
                         "output_interval": 1})
        return tests, name
    return tests, None


def set_strain_scene_interval(tests, name, deck_plan):
    """The strain scene writes about STRAIN_SCENE_ROWS rows: its output interval from its planned steps."""
    for t in tests:
        if t["name"] == name:
            t["output_interval"] = max(1, binary.test_plan(deck_plan, name)["steps"] // STRAIN_SCENE_ROWS)


def derived_deck(deck, state, tests, code, variant=None):
    """The deck matched to `code`'s contact model, or with one model choice changed (VARIANTS), or the
    deck's own settings (variant "native"), all starting from `state`."""
    d = copy.deepcopy(deck)
    d.pop("prepare", None)
    d["initial_state"] = state
    d["override_state_physics"] = True  # matched to the code's contact model: other physics than the state's
    d["tests"] = tests
    what = ("native settings" if variant == "native"
            else "matched to %s%s" % (code, ", variant " + variant if variant else ""))
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


def kind_of(test):
    return "a" if all("stress" not in ax for ax in test["axes"].values()) else "b"


# ---- running -------------------------------------------------------------------------------------------

def sh(cmd, cwd=None, log=None, env=None):
    t0 = time.time()
    with open(log, "w") if log else open(os.devnull, "w") as out:
        r = subprocess.run(cmd, cwd=cwd, stdout=out, stderr=subprocess.STDOUT, env=env)
    if r.returncode != 0:
        fail("failed (%d): %s%s" % (r.returncode, " ".join(cmd), " (see %s)" % log if log else ""))
    return time.time() - t0


def mpi_env():
    env = dict(os.environ)
    if hasattr(os, "geteuid") and os.geteuid() == 0:  # Open MPI refuses root unless told
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    return env


def run_celldem(args, deck, folder):
    """Runs celldem on `deck` in folder/celldem (kept with --reuse when the same deck finished there)."""
    os.makedirs(folder, exist_ok=True)
    deck_path = os.path.join(folder, "deck.json")
    run_dir = os.path.join(folder, "celldem")
    summary = read_json(os.path.join(run_dir, "summary.json"))
    if args.reuse and summary and read_json(deck_path) == deck \
            and all(t["name"] in summary.get("tests", {}) for t in deck["tests"]):
        return run_dir, None
    with open(deck_path, "w") as f:
        json.dump(deck, f, indent=2)
    cmd = binary.run_command(deck_path, run_dir, threads=args.threads or None, force=True, quiet=True,
                             binary=args.celldem)
    wall = sh(cmd, log=os.path.join(folder, "celldem.log"))
    return run_dir, wall


def translate(args, folder, code):
    out = os.path.join(folder, code)
    r = subprocess.run([args.celldem, "translate", os.path.join(folder, "deck.json"), "--to", code, "--out", out,
                        "--force"], capture_output=True, text=True)
    if r.returncode != 0:
        fail("celldem translate failed:\n" + r.stderr)
    warnings = [line.split("warning: ", 1)[1] for line in r.stderr.splitlines() if "warning: " in line]
    with open(os.path.join(folder, "warnings.txt"), "w") as f:
        f.write("\n".join(warnings) + ("\n" if warnings else ""))
    return out, warnings


def last_printed_step(test_plan):
    """The step of the last row a translated script prints: fix print writes every output_interval steps."""
    return test_plan["steps"] - test_plan["steps"] % test_plan["output_interval"]


def last_step(path):
    try:
        with open(path) as f:
            rows = [line for line in f.read().splitlines() if line and line[0].isdigit()]
        return int(rows[-1].split(",")[0]) if rows else -1
    except OSError:
        return -1


def run_code(args, code, script_dir, test_plan, np_ranks, tag=""):
    """Runs the translated script of a test; tag names a second run of the same script (another output)."""
    stem = "%s.%s%s" % (test_plan["name"], code, tag)
    series = os.path.join(script_dir, stem + ".csv")
    if args.reuse and os.path.exists(series) and last_step(series) >= last_printed_step(test_plan):
        return series, None
    cmd = [EXE[code], "-in", "%s.%s.in" % (test_plan["name"], code), "-var", "out", stem + ".csv",
           "-log", stem + ".log", "-screen", "none"]
    if np_ranks > 1:
        cmd = ["mpirun", "-np", str(np_ranks)] + cmd
    wall = sh(cmd, cwd=script_dir, env=mpi_env())
    return series, wall


# ---- comparisons ---------------------------------------------------------------------------------------

class Side:
    """One side of a comparison: a series and its summary.json quantities (celldem's own, or `celldem summarize`'s)."""

    def __init__(self, series, quantities):
        self.series, self.quantities = series, quantities

    @classmethod
    def celldem(cls, run_dir, test):
        summary = read_json(os.path.join(run_dir, "summary.json")) or {}
        return cls(load_series(os.path.join(run_dir, test, "series.csv")), (summary.get("tests") or {}).get(test) or {})

    @classmethod
    def other_code(cls, path, end_axis, celldem=None):
        return cls(load_series(path), binary.summarize(path, end_axis, celldem))


def compare_strain_scene(ref, other, tol, hold):
    """Kind (a): relative stress difference per row against e1; the e1 up to which it stays below tol."""
    ref, other = ref.series, other.series
    e = ref["e1"]
    rel = np.full(len(e), np.nan)
    for k in ("s11", "s22", "s33"):
        d = np.abs(on_grid(e, other["e1"], other[k]) - ref[k]) / np.abs(ref[k])
        rel = np.fmax(rel, d)
    dz = np.abs(on_grid(e, other["e1"], other["Z"]) - ref["Z"])
    valid = ~np.isnan(rel)
    bad = valid & (rel >= tol)
    holds_to = e[valid][-1] if not bad.any() else (e[valid & (e < e[bad][0])].max(initial=0.0))
    in_range = valid & (e <= hold + 1e-12)
    return {"kind": "a", "tolerance": tol, "required_e1": hold, "holds_to_e1": float(holds_to),
            "max_rel_stress_diff_to_required": float(np.nanmax(rel[in_range])) if in_range.any() else None,
            "max_abs_Z_diff_to_required": float(np.nanmax(dz[in_range])) if in_range.any() else None,
            "rel_stress_diff_at_end": float(rel[valid][-1]), "final_e1": float(e[valid][-1]),
            "pass": bool(holds_to >= hold - 1e-12),
            "curve": {"e1": e.tolist(), "rel": rel.tolist()}}


def servo_lag(series, targets):
    """Mean and std of (stress - target) of each stress-controlled axis over the second half of e1."""
    half = series["e1"] >= 0.5 * series["e1"].max()
    return {"lag_" + key: [float(np.mean(series[key][half] - t)), float(np.std(series[key][half] - t))]
            for key, t in targets.items()}


def mixed_values(side, targets):
    """The compared quantities of one side (MIXED_CHECKS), the plateau, the final e1 and the servo lag."""
    q = side.quantities
    out = {key: get(q, key) for key in MIXED_CHECKS}
    out.update(e1_at_peak=q.get("e1_at_peak"), e1_peak_range=q.get("e1_peak_range") or [None, None],
               final_e1=q.get("final_e1"), end_window_strain=get(q, "end_window.strain"))
    out.update(servo_lag(side.series, targets))
    return out


def compare_mixed(ref, other, test, args):
    """Kind (b): summary.json's quantities of celldem against the same quantities of the other code's series."""
    targets = {"s%s%s" % (a[1], a[1]): ax["stress"] for a, ax in test["axes"].items() if "stress" in ax}
    a, b = mixed_values(ref, targets), mixed_values(other, targets)
    tolerance = {"peak_ratio13": args.tol_peak, "e1_at_peak_centre": args.tol_e1_peak, "ev_final": args.tol_ev,
                 "end_window.Z": args.tol_z}
    checks = {}
    for key, (_, how) in MIXED_CHECKS.items():
        if a[key] is None or b[key] is None:
            diff = math.inf
        else:
            diff = abs(b[key] / a[key] - 1.0) if how == "relative" else abs(b[key] - a[key])
        checks[key] = {"diff": float(diff), "tolerance": tolerance[key], "how": how,
                       "pass": bool(diff <= tolerance[key])}
    ratio_ref = column(ref.series, "ratio13")
    ratio_o = on_grid(ref.series["e1"], other.series["e1"], column(other.series, "ratio13"))
    rr = np.abs(ratio_o / ratio_ref - 1.0)
    return {"kind": "b", "celldem": a, "code": b, "checks": checks,
            "ratio13_rel_diff_max": float(np.nanmax(rr)), "ratio13_rel_diff_rms": float(np.sqrt(np.nanmean(rr ** 2))),
            "pass": all(c["pass"] for c in checks.values())}


def compare(ref, other, test, args, code):
    return (compare_strain_scene(ref, other, args.tol_stress, args.hold_e1[code]) if kind_of(test) == "a"
            else compare_mixed(ref, other, test, args))


def variant_values(side, test):
    """What a model variant changes: the end stresses of the strain scene, summary.json's quantities otherwise."""
    if kind_of(test) == "a":
        s = side.series
        return {"s11 at end": float(s["s11"][-1]), "s22 at end": float(s["s22"][-1]), "Z at end": float(s["Z"][-1])}
    return {label: get(side.quantities, key) for key, (label, _) in MIXED_CHECKS.items()}


# ---- plots and report ------------------------------------------------------------------------------------

def plot_test(path, test, curves, comparisons):
    plt = plotting.pyplot()
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
            a.plot(100 * s["e1"], column(s, "ratio13"), label=name, lw=1)
        a.set_ylabel("s11/s33 (stresses held)")
    a.set_xlabel("e1 [%]")
    a.grid(alpha=0.3)
    ax.flat[0].legend(fontsize=8)
    fig.suptitle("%s (kind %s): celldem versus the target codes on the same state" % (test["name"], kind))
    plotting.save(fig, path, dpi=90)


def verdict(ok, comparison):
    return "(noise, no check)" if comparison.get("informational") else ("pass" if ok else "**FAIL**")


def strain_scene_rows(comparisons):
    return [(name, "%s %%" % fmt_spec(100 * c["holds_to_e1"], ".3g"),
             "%s %% (tol %s)" % (fmt_spec(100 * c["required_e1"], ".3g"), fmt_spec(c["tolerance"], ".0e")),
             fmt_spec(c["max_rel_stress_diff_to_required"], ".2e"), fmt_spec(c["max_abs_Z_diff_to_required"], ".3f"),
             "%s (%s %%)" % (fmt_spec(c["rel_stress_diff_at_end"], ".2e"), fmt_spec(100 * c["final_e1"], ".3g")),
             verdict(c["pass"], c)) for name, c in comparisons.items()]


def mixed_rows(comparisons):
    rows = []
    for name, c in comparisons.items():
        a, b = c["celldem"], c["code"]
        for key, chk in c["checks"].items():
            rows.append((name, MIXED_CHECKS[key][0], fmt_spec(a[key]), fmt_spec(b[key]), fmt_spec(chk["diff"], ".3g"),
                         "%s (%s)" % (fmt_spec(chk["tolerance"], ".3g"), chk["how"]), verdict(chk["pass"], c)))
        rows.append((name, "e1 at the maximum; range within 1 % of it",
                     *("%s; %s–%s" % (fmt_spec(v["e1_at_peak"]), *(fmt_spec(x) for x in v["e1_peak_range"]))
                       for v in (a, b)), "", "", ""))
        rows.append((name, "e1 at the end; end window (e1)", "%s; %s" % (fmt_spec(a["final_e1"]),
                                                                         fmt_spec(a["end_window_strain"])),
                     "%s; %s" % (fmt_spec(b["final_e1"]), fmt_spec(b["end_window_strain"])), "", "", ""))
        lags = ", ".join("%s %+.0f ± %.0f Pa (celldem %+.0f)" % (k[4:], v[0], v[1], a[k][0])
                         for k, v in b.items() if k.startswith("lag_"))
        rows.append((name, "servo lag (2nd half)", "", lags, "", "", ""))
        rows.append((name, "s11/s33 curve, rel. diff max / rms", "", "",
                     "%.3g / %.3g" % (c["ratio13_rel_diff_max"], c["ratio13_rel_diff_rms"]), "", ""))
    return rows


def write_report(out, report):
    lines = ["# celldem cross-check", "",
             "Deck `%s`, state `%s`, %d particles; codes %s, %d MPI rank(s). celldem's quantities are its "
             "summary.json's; the other code's are computed from its series by the same definitions "
             "(`celldem summarize`)." %
             (report["deck"], report["state"], report["particles"], ", ".join(report["codes"]), report["np"]), ""]
    for test in report["tests"]:
        lines += ["## %s (kind %s)" % (test["name"], test["kind"]), "",
                  "![%s](%s.png)" % (test["name"], test["name"]), ""]
        if test["kind"] == "a":
            lines.append(md_table(("pair", "holds to e1", "required", "max rel. stress diff to required",
                                   "max dZ to required", "rel. diff at end (e1)", "pass"),
                                  strain_scene_rows(test["comparisons"])))
        else:
            lines.append(md_table(("pair", "quantity", "celldem", "code", "difference", "tolerance", "pass"),
                                  mixed_rows(test["comparisons"])))
        if test.get("variants"):
            lines += ["", "celldem model variants against the LAMMPS-matched celldem run (same state):", "",
                      md_table(("variant", "quantity", "value", "matched", "difference"),
                               [(name, key, fmt_spec(val), fmt_spec(ref),
                                 fmt_spec(None if val is None or ref is None else val - ref, ".3g"))
                                for name, v in test["variants"].items() for key, (val, ref) in v.items()])]
        lines.append("")
    lines += ["## Warnings from `celldem translate` (matched decks)", ""]
    for code, ws in report["warnings"].items():
        lines += ["- %s: %s" % (code, w) for w in ws] or ["- %s: none" % code]
    lines += ["", "## Wall times [s]", ""] + ["- %s: %s" % (k, fmt_spec(v, ".1f")) for k, v in report["wall"].items()]
    lines += ["", "Overall: **%s**" % ("pass" if report["pass"] else "FAIL"), ""]
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(lines))


# ---- the whole cross-check -----------------------------------------------------------------------------

def check_codes(codes):
    for c in codes:
        if c not in EXE:
            fail("unknown code %s" % c)
        if not shutil.which(EXE[c]):
            fail("%s not found (tools/install-deps.sh --with-crosscheck installs it)" % EXE[c])


def plan_scene(args, deck, state):
    """The scene's tests (strain scene included, its output interval set) and the plan of the derived decks."""
    try:
        tests, strain_scene = scene_tests(deck, binary.plan(args.deck, args.celldem), args)
        if strain_scene:
            probe = derived_deck(deck, state, tests, "lammps")
            set_strain_scene_interval(tests, strain_scene, binary.plan_deck(probe, args.out, args.celldem))
        return tests, binary.plan_deck(derived_deck(deck, state, tests, "lammps"), args.out, args.celldem)
    except binary.BinaryError as err:
        fail(str(err))


def run(args):
    """Runs the cross-check of parse_args' `args`; returns 0 when every check passes, 1 otherwise."""
    deck = load_json(args.deck)
    state = resolve_state(args.deck, deck, args.state)
    if not os.path.exists(state):
        fail("no state file %s" % state)
    codes = [c for c in args.codes.split(",") if c]
    check_codes(codes)
    variants = [v for v in args.variants.split(",") if v]
    for v in variants:
        if v not in VARIANTS and v != "native":
            fail("unknown variant %s (known: native, %s)" % (v, ", ".join(VARIANTS)))
    os.makedirs(args.out, exist_ok=True)
    tests, scene_plan = plan_scene(args, deck, state)
    report = {"deck": args.deck, "state": state, "codes": codes, "np": args.np, "tests": [], "warnings": {},
              "wall": {}, "particles": scene_plan["sample"]["count"]}

    runs = {}  # name -> (celldem run dir, code script dir or None)
    for code in codes:
        folder = os.path.join(args.out, code)
        run_dir, report["wall"]["celldem (%s-matched)" % code] = run_celldem(
            args, derived_deck(deck, state, tests, code), folder)
        script_dir, report["warnings"][code] = translate(args, folder, code)
        runs[code] = (run_dir, script_dir)
    for v in variants:
        run_dir, report["wall"]["celldem (%s)" % v] = run_celldem(
            args, derived_deck(deck, state, tests, "lammps", variant=v), os.path.join(args.out, "variant-" + v))
        runs["variant-" + v] = (run_dir, None)

    ok = True
    for test in tests:
        name, kind = test["name"], kind_of(test)
        test_plan = binary.test_plan(scene_plan, name)
        curves, comps, variant_diffs = {}, {}, {}
        for code in codes:
            ref = Side.celldem(runs[code][0], name)
            series, report["wall"]["%s %s (np %d)" % (code, name, args.np)] = run_code(
                args, code, runs[code][1], test_plan, args.np)
            other = Side.other_code(series, test_plan["end_axis"], args.celldem)
            curves["celldem (%s-matched)" % code], curves[code] = ref.series, other.series
            comps["celldem vs " + code] = compare(ref, other, test, args, code)
            ok &= comps["celldem vs " + code]["pass"]
            if args.noise:  # the same script on another rank count: round-off only, amplified by the dynamics
                other_np = 2 if args.np == 1 else 1
                series2, report["wall"]["%s %s (np %d)" % (code, name, other_np)] = run_code(
                    args, code, runs[code][1], test_plan, other_np, tag=".np%d" % other_np)
                again = Side.other_code(series2, test_plan["end_axis"], args.celldem)
                noise = compare(other, again, test, args, code)
                noise["informational"] = True
                comps["%s np%d vs np%d (noise floor)" % (code, args.np, other_np)] = noise
        base = Side.celldem(runs[codes[0]][0], name) if codes else None
        for key in [k for k in runs if k.startswith("variant-")]:
            side = Side.celldem(runs[key][0], name)
            curves["celldem " + key[8:]] = side.series
            if base is not None:
                vm, bm = variant_values(side, test), variant_values(base, test)
                variant_diffs[key[8:]] = {k: (vm[k], bm[k]) for k in vm if k in bm}
        plot_test(os.path.join(args.out, name + ".png"), test, curves, comps)
        for c in comps.values():
            c.pop("curve", None)
        report["tests"].append({"name": name, "kind": kind, "comparisons": comps, "variants": variant_diffs})
    report["pass"] = bool(ok)
    with open(os.path.join(args.out, "report.json"), "w") as f:
        json.dump(report, f, indent=2)
    write_report(args.out, report)
    print("run_crosscheck: %s; report in %s" % ("pass" if ok else "FAIL", os.path.join(args.out, "report.md")))
    return 0 if ok else 1
