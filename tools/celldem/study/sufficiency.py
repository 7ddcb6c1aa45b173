"""Model sufficiency (tools/sufficiency.py): which of a deck's sub-models and model terms change its results.

A deck is run on a reduced scene (sample.count and the tests' end strain lowered, everything else the deck's)
over several seeds, once as it is (the baseline) and once per switch, each switch making one sub-model or term
one step simpler, the others as the deck has them:

    normal      hertz -> linear, kn = the secant stiffness F/overlap at the mean contact force
    tangential  mindlin (or mindlin_rescale) -> linear_history, kt = 8 G* a at that same overlap (a = sqrt(R* overlap))
    rolling     sds -> none
    twisting    marshall -> none
    rotational damping  damping.rotational -> 0
    kinematics  affine -> lammps (contacts across periodic images do not see the affine velocity difference)

The mean contact is `celldem plan`'s mean_contact (core/plan's definitions): the force pi d^2 p / (Z phi) under
the deck's confining stress p (its largest stress, as celldem's reference overlap reads it), d the sample's mean
diameter, its overlap that of two spheres of that diameter (R* = d / 4) by the deck's normal law, the secant kn
and the Mindlin kt there. Which contact keys a switched law keeps is `celldem schema`'s sub_models. A switch that changes the reference stiffness (normal, tangential)
would change the absolute body damping, which celldem scales with it; the variant's damping fractions are
rescaled so that its drag coefficients (`celldem plan` particle_types[].translational_drag, rotational_drag)
stay the baseline's: the switch changes the contact law only.

Each seed's sample is prepared once, with the baseline deck (the preparation is frictionless: friction, rolling
and twisting resistance act in the tests only), and the baseline and every variant run their tests from it, as
the speed–accuracy study's modelling runs do (tools/study.py). Running is study_runs.run_all's (resumable,
`--jobs` runs at once, each single-threaded); the quantities are summary.json's (celldem's definitions: the
robust peak fields peak_robust.ratio13, .e1 and .b_mean when present, end_window.ev and .Z), the noise floor
study_analysis.noise_floor's (the seed-to-seed standard deviation of the baseline, ddof 1).

The change of a variant is judged on paired differences: baseline and variant run their tests from the same
prepared sample, so each seed gives d = variant - baseline. Per quantity: a one-sample t-test of the mean of d
against 0 (n - 1 degrees of freedom, scipy.stats), and two one-sided t-tests (TOST) that |mean d| is below a
margin of MARGIN_FLOORS noise floors (the baseline's seed-to-seed standard deviation). The floor is estimated from
the same few baseline seeds (3 dof with 4 seeds), so the margin is not taken at the estimate s but at the floor's
lower confidence limit s sqrt(k / chi2(MARGIN_LEVEL, k)), k = the baseline's seeds - 1 (scipy.stats.chi2): the
margin then exceeds MARGIN_FLOORS true floors with probability at most 1 - MARGIN_LEVEL, and the TOST is run at
TOST_ALPHA; a true change of MARGIN_FLOORS floors or more is called "within margin" with probability at most
(1 - MARGIN_LEVEL) + TOST_ALPHA = ALPHA (a union bound, whatever the dependence between the floor and the paired
differences). With the margin at the estimate itself that error rate was 22.8 % (4 seeds, paired-difference sd
0.2 floor); tests/tools/test_sufficiency_stats.py measures it by simulation for the rule here. Per switch:
- "needed": some quantity changes, i.e. its t-test rejects 0 after Holm's adjustment over the switch's quantities
  (family-wise error rate ALPHA: the chance that a switch that changes nothing is called needed is at most ALPHA)
  and the change is not equivalent to 0 within the margin (a significant but negligible change, such as a
  systematic round-off shift, is not a need);
- "not needed": every quantity is equivalent to no change within the margin (TOST at TOST_ALPHA each within
  the floor's lower confidence limit, together an error rate of at most ALPHA per quantity; an intersection-union
  test, whose error rate is that of one quantity without adjustment);
- "undecided at n seeds" otherwise.
Beside each quantity the smallest change the run detects with 80 % power at Holm's strictest level ALPHA / m
(the noncentral t distribution, scipy.stats.nct; not the normal approximation), from the paired differences'
standard deviation: a switch "undecided" with a detectable change above the margin needs more seeds.
"""

import copy
import hashlib
import json
import math
import os
import shutil
import time

import numpy as np
from scipy import stats as sps

from .. import binary, decks, stats
from . import runs as study_runs
from ..results import number, read_json
from ..stats import describe
from .analysis import noise_floor, test_metrics
from .scene import QUANTITY_LABELS
from ..reports.tables import fmt, md_table

DEFAULT_COUNT = 300          # spheres of the reduced scene
DEFAULT_END_STRAIN = 0.04    # the tests' end strain on the reduced scene (rolling resistance moves the peak late)
DEFAULT_SEEDS = (1, 2, 3, 4)
ALPHA = 0.05                 # family-wise error rate of "needed" per switch (Holm), and of "not needed"
MARGIN_FLOORS = 1.0          # "not needed": the change is within this many (true) noise floors (TOST)
# "not needed" splits ALPHA: the margin is the floor's lower confidence limit at MARGIN_LEVEL, the TOST is at
# TOST_ALPHA (a union bound: a true change of MARGIN_FLOORS is called within the margin at most ALPHA of the time)
MARGIN_LEVEL = 1.0 - ALPHA / 2.0
TOST_ALPHA = ALPHA / 2.0
POWER = 0.8                  # the smallest detectable change is given at this power

QUANTITY_ORDER = ("peak_ratio", "e1_peak", "ev_end", "Z_end", "b_peak")
PEAK_QUANTITIES = ("peak_ratio", "e1_peak", "b_peak")  # left out of a test whose summary says "peak_reached": false
PERCENT = {"e1_peak", "ev_end"}
ROBUST_KEYS = {"peak_ratio": "peak_robust.ratio13", "e1_peak": "peak_robust.e1", "b_peak": "peak_robust.b_mean"}
SUMMARY_TEXT = {"peak_ratio": "peak_robust.ratio13 (else peak_ratio13)", "e1_peak": "peak_robust.e1 (else e1_at_peak)",
                "b_peak": "peak_robust.b_mean (else b_at_peak)", "ev_end": "end_window.ev", "Z_end": "end_window.Z"}

# A switch that changes nothing physical, for calibration (--switches round_off): chaotic runs make it differ by
# round-off only, so it must never be "needed".
CALIBRATION_SWITCHES = (("round_off", "time_step × (1 + 1e-9) (round-off only, calibration)"),)

SWITCHES = (
    ("normal", "normal: hertz → linear"),
    ("tangential", "tangential: mindlin → linear_history"),
    ("rolling", "rolling: sds → none"),
    ("twisting", "twisting: marshall → none"),
    ("rotational_damping", "rotational damping → 0"),
    ("kinematics", "kinematics: affine → lammps (affine term off)"),
)

# Each contact-law switch: the sub-model and the simpler choice it switches to.
SIMPLER_CHOICE = {"normal": "linear", "tangential": "linear_history", "rolling": "none", "twisting": "none"}


# ---- the reduced scene and the variants -----------------------------------------------------------------------

def reduce_deck(deck, count, end_strain):
    """The deck on the reduced scene: sample.count = count, each test's strain end at end_strain (a test given by
    legs is kept as it is); everything else the deck's."""
    out = decks.edited(deck, {"sample.count": count})
    for t in out.get("tests", []):
        end = t.get("end")
        if isinstance(end, dict) and "strain" in end:
            end["strain"] = math.copysign(end_strain, end["strain"])
    return out


def mean_contact(deck_plan):
    """The mean contact under the deck's confining stress, `celldem plan`'s mean_contact under this tool's names:
    pressure (the confining stress p), mean_diameter d, force pi d^2 p / (Z phi), r_eff = d/4, overlap by the
    deck's normal law, kn_secant = force/overlap, contact_radius a = sqrt(r_eff overlap), kt_mindlin = 8 G* a
    (None without E and nu), z_phi; None when the deck names no stress."""
    m = deck_plan.get("mean_contact")
    if m is None:
        return None
    return {"pressure": m["confining_stress"], "mean_diameter": m["mean_diameter"], "force": m["force"],
            "r_eff": m["effective_radius"], "overlap": m["overlap"], "kn_secant": m["secant_normal_stiffness"],
            "contact_radius": m["contact_radius"], "kt_mindlin": m["mindlin_tangential_stiffness"],
            "z_phi": m["z_phi"]}


def chosen(deck, sub_model, schema):
    """The deck's choice of a contact sub-model ("normal", ...), its default from `celldem schema` when not given."""
    default = next(e["default"] for e in schema if e["key"] == f"contact.{sub_model}")
    return deck["contact"].get(sub_model, default)


def clean(deck, schema):
    """The deck without the keys of contact sub-model choices it does not make (`celldem schema`'s sub_models,
    which celldem refuses): in contact, prepare and each test. Changes `deck` in place and returns it."""
    made = {}
    for entry in schema:
        uses = entry.get("sub_models")
        if not uses:
            continue
        for u in uses:
            made.setdefault(u["sub_model"], chosen(deck, u["sub_model"], schema))
        if any(made[u["sub_model"]] in u["choices"] for u in uses):
            continue
        parent, name = entry["key"].rsplit(".", 1)
        owners = {"contact": [deck.get("contact")], "prepare": [deck.get("prepare")],
                  "tests[]": deck.get("tests", [])}.get(parent, [])
        for owner in owners:
            if isinstance(owner, dict):
                owner.pop(name, None)
    return deck


def switch_applies(deck, key, schema):
    """(applies, why not) of a switch for a deck: a contact-law switch applies unless the deck already makes the
    simpler choice."""
    have = {k: (chosen(deck, k, schema) != simpler, f"{k} is {chosen(deck, k, schema)}")
            for k, simpler in SIMPLER_CHOICE.items()}
    have.update({"rotational_damping": ((number(deck["damping"].get("rotational")) or 0.0) > 0.0,
                                   "damping.rotational is 0"),
            "kinematics": (deck.get("kinematics", "affine") == "affine", f"kinematics is {deck.get('kinematics')}"),
            "round_off": (True, None)})
    ok, why = have[key]
    return ok, None if ok else f"skipped: {why}"


def switched(deck, key, contact_mean, schema):
    """(the deck with switch `key` applied, {what was set}); the damping is rescaled later (keep_drag)."""
    out = copy.deepcopy(deck)
    c = out["contact"]
    note = {}
    if key == "normal":
        c["normal"] = SIMPLER_CHOICE["normal"]
        c["kn"] = contact_mean["kn_secant"]
        note = {"kn": c["kn"]}
    elif key == "tangential":
        c["tangential"] = SIMPLER_CHOICE["tangential"]
        c["kt"] = contact_mean["kt_mindlin"]
        note = {"kt": c["kt"]}
    elif key == "rolling":
        c["rolling"] = SIMPLER_CHOICE["rolling"]
    elif key == "twisting":
        c["twisting"] = SIMPLER_CHOICE["twisting"]
    elif key == "rotational_damping":
        out["damping"]["rotational"] = 0.0
    elif key == "kinematics":
        out["kinematics"] = "lammps"
    elif key == "round_off":
        out["time_step"] = deck["time_step"] * (1.0 + 1e-9)
        note = {"time_step": out["time_step"]}
    return clean(out, schema), note


def keep_drag(base_plan, variant, celldem):
    """The variant with its damping fractions rescaled so that its drag coefficients are the baseline's (a
    contact-law switch changes the reference stiffness that celldem scales the damping with); returns
    (deck, {"translational": factor, "rotational": factor}) with the factors applied (1 when unchanged)."""
    plan = binary.plan_deck(variant, None, celldem)
    factors = {}
    out = copy.deepcopy(variant)
    for kind in ("translational", "rotational"):
        b = base_plan["particle_types"][0][f"{kind}_drag"]
        v = plan["particle_types"][0][f"{kind}_drag"]
        f = b / v if v > 0 and b > 0 else 1.0
        if abs(f - 1.0) > 1e-9:
            out["damping"][kind] = out["damping"][kind] * f
        factors[kind] = f if abs(f - 1.0) > 1e-9 else 1.0
    return out, factors


def variants(deck, celldem, keys=None):
    """[(key, label, deck or None, info)] for the baseline ("baseline") and each switch (those named in `keys`
    when given, from SWITCHES and CALIBRATION_SWITCHES); deck None: skipped (info["skipped"] says why). `deck` is
    the reduced deck."""
    plan = binary.plan_deck(deck, None, celldem)
    schema = binary.schema(celldem)
    cm = mean_contact(plan)
    out = [("baseline", "baseline (the deck as it is)", deck, {"mean_contact": cm})]
    table = SWITCHES if keys is None else [(k, l) for k, l in SWITCHES + CALIBRATION_SWITCHES if k in keys]
    for key, label in table:
        ok, why = switch_applies(deck, key, schema)
        no_mean = cm is None or (key == "tangential" and cm["kt_mindlin"] is None)
        if ok and key in ("normal", "tangential") and no_mean:
            ok, why = False, "skipped: the deck names no stress to place the mean contact force"
        if not ok:
            out.append((key, label, None, {"skipped": why}))
            continue
        v, set_ = switched(deck, key, cm, schema)
        v, factors = keep_drag(plan, v, celldem)
        out.append((key, label, v, {"set": set_, "damping_factors": factors,
                                    "damping": dict(v["damping"]), "contact": v["contact"],
                                    "kinematics": v.get("kinematics", "affine")}))
    return out


# ---- the runs ----------------------------------------------------------------------------------------------------

def deck_hash(deck):
    return hashlib.sha256(json.dumps(deck, sort_keys=True).encode()).hexdigest()[:16]


def build_plan(deck, configs, seeds):
    """Specs for study_runs.run_all: one preparation per seed (the baseline deck without tests), then the baseline's
    and each variant's tests from it. Each spec carries its deck (study_runs.deck_of uses it)."""
    count = deck["sample"]["count"]
    specs = []
    for seed in seeds:
        sd = decks.edited(deck, {"sample.seed": seed})
        specs.append({"name": f"sample_s{seed}", "kind": "sample", "group": "sample",
                      "label": f"{count} spheres, seed {seed}", "count": count, "seed": seed, "priority": 0,
                      "deck": sd, "tests": []})
    for i, (key, label, vdeck, _) in enumerate(configs):
        if vdeck is None:
            continue
        for seed in seeds:
            sd = decks.edited(vdeck, {"sample.seed": seed})
            specs.append({"name": f"{key}_s{seed}", "kind": "test", "group": key, "label": label,
                          "count": count, "seed": seed, "priority": 1 + i, "sample": f"sample_s{seed}",
                          "sample_deck": deck_hash(decks.edited(deck, {"sample.seed": seed})), "deck": sd,
                          "tests": [t["name"] for t in sd.get("tests", [])]})
    order = {s["name"]: i for i, s in enumerate(specs)}
    # seeds first, so that every configuration has some seeds early (the runs of one seed share its sample)
    return sorted(specs, key=lambda s: (s["kind"] != "sample", s["seed"], order[s["name"]]))


def drop_stale(root, specs):
    """Removes the run folders whose spec.json differs from the spec now planned (another deck or scene)."""
    removed = 0
    for s in specs:
        d = study_runs.run_dir(root, s)
        old = read_json(os.path.join(d, "spec.json"))
        if old is not None and json.loads(json.dumps(s)) != old:
            shutil.rmtree(d)
            removed += 1
    return removed


def run(root, deck, configs, seeds, celldem, jobs=2):
    """Runs what is missing (`jobs` at a time); its wall time goes into ROOT/timing.json (the cost the report
    states). Returns the specs."""
    specs = build_plan(deck, configs, seeds)
    os.makedirs(root, exist_ok=True)
    stale = drop_stale(root, specs)
    if stale:
        print(f"sufficiency: {stale} runs of another deck or scene removed", flush=True)
        study_runs.remove_quietly(os.path.join(root, "timing.json"))  # its times were of those runs
    todo = [s for s in specs if not study_runs.is_done(root, s)]
    n_todo = len(todo)
    print(f"sufficiency: {len(todo)} runs to do of {len(specs)} ({jobs} at a time); results in {root}", flush=True)
    study_runs.record_binary(root, celldem)
    t0 = time.monotonic()
    study_runs.run_all(root, None, specs, todo, celldem, jobs)
    wall = time.monotonic() - t0
    timing = read_json(os.path.join(root, "timing.json")) or {"invocations": []}
    if n_todo:
        timing["invocations"].append({"runs": n_todo, "jobs": jobs, "wall_s": wall,
                                      "finished": time.strftime("%Y-%m-%d %H:%M:%S")})
    study_runs.write_json(os.path.join(root, "timing.json"), timing)
    return specs


# ---- the analysis ----------------------------------------------------------------------------------------------

def quantities_of(deck):
    """[(test, quantity)] compared for a deck: peak ratio, e1 at peak, ev and Z at the end for every test; b at
    the peak for tests whose two lateral axes differ (not axisymmetric) and whose b is not prescribed."""
    out = []
    for t in deck.get("tests", []):
        qs = ["peak_ratio", "e1_peak", "ev_end", "Z_end"]
        axes = t.get("axes") or ((t.get("legs") or [{}])[0].get("axes") or {})
        x2, x3 = axes.get("x2"), axes.get("x3")
        prescribed = any(isinstance(a, dict) and "b" in a for a in axes.values())
        if x2 is not None and x2 != x3 and not prescribed:
            qs.append("b_peak")
        out += [(t["name"], q) for q in qs]
    return out


def summary_value(info, path):
    v = info
    for part in path.split("."):
        v = v.get(part) if isinstance(v, dict) else None
    return number(v)


def run_metrics(summary, end_strain):
    """{test: {quantity: value}} of a run's summary.json: the study's (test_metrics: e1_at_peak, end_window, ...,
    end values only when the run reached its end), the peak ones replaced by summary.json's robust peak fields
    where it has them."""
    out = {}
    for test, info in (summary.get("tests") or {}).items():
        if not isinstance(info, dict):
            continue
        m = test_metrics(info, end_strain)
        for q, path in ROBUST_KEYS.items():
            v = summary_value(info, path)
            if v is not None:
                m[q] = v
        out[test] = m
    return out


def paired(base_by_seed, variant_by_seed):
    """The per-seed differences variant - baseline over the seeds both have, in seed order."""
    return [variant_by_seed[k] - base_by_seed[k] for k in sorted(base_by_seed) if k in variant_by_seed]


def equivalence_margin(floor, floor_n, margin_floors=MARGIN_FLOORS, level=MARGIN_LEVEL):
    """margin_floors x the noise floor's lower confidence limit at `level`: s sqrt(k / chi2.ppf(level, k)) with
    k = floor_n - 1 the dof of the floor s (a standard deviation over floor_n seeds); it exceeds margin_floors
    true floors with probability 1 - level. Takes numpy arrays; None for a scalar floor_n below 2."""
    if np.isscalar(floor_n) and floor_n < 2:
        return None
    k = np.asarray(floor_n) - 1
    return margin_floors * floor * np.sqrt(k / sps.chi2.ppf(level, k))


def within_margin(mean, sem, n, margin, alpha=TOST_ALPHA):
    """Whether TOST at `alpha` finds |mean of n paired differences| below `margin`, vectorised (numpy arrays):
    both one-sided p <= alpha, i.e. |mean| + t(1 - alpha, n - 1) sem <= margin (stats.tost's rule)."""
    return np.abs(mean) + sps.t.ppf(1.0 - alpha, np.asarray(n) - 1) * sem <= margin


def change(differences, floor, n_quantities=1, margin_floors=MARGIN_FLOORS, alpha=ALPHA, detectable=True,
           floor_n=None):
    """One quantity's change from its paired differences: {"delta" (mean difference), "diff" (describe of the
    differences), "floor", "floor_n" (the seeds it was estimated from), "noise_units" (delta / floor), "margin"
    (equivalence_margin: margin_floors x the floor's lower confidence limit), "p" (paired t, two-sided), "p_tost",
    "detectable" (the smallest change detected with POWER at alpha / n_quantities)}; None without values
    (detectable False: not computed, for simulations). floor_n None: the floor's seeds are taken to be the paired
    seeds (as in the tool, where the baseline is one side of each pair). The verdict is set by judge_switch (it
    needs the switch's other quantities)."""
    d = describe(differences)
    if d is None:
        return None
    floor_n = d["n"] if floor_n is None else floor_n
    out = {"delta": d["mean"], "diff": d, "n": d["n"], "floor": floor, "floor_n": floor_n, "noise_units": None,
           "margin": None, "p": stats.one_sample_p(d), "p_tost": None, "p_holm": None,
           "detectable": stats.smallest_detectable(d["n"], d["std"], alpha / max(1, n_quantities), POWER)
           if detectable else None}
    if floor is not None and floor > 0.0:
        out["noise_units"] = d["mean"] / floor
        margin = equivalence_margin(floor, floor_n, margin_floors, 1.0 - alpha / 2.0)
        out["margin"] = None if margin is None else float(margin)
    if out["margin"] is not None:
        t = stats.tost(d, out["margin"])
        out["p_tost"] = None if t is None else t["p"]
    return out


def judge_switch(changes, alpha=ALPHA):
    """Sets each change's "p_holm" and "verdict" ("changes", "within margin", "undecided", or "untested" with
    fewer than two paired seeds, e.g. a peak quantity where only one seed reached a peak) and returns the switch's
    verdict over its testable quantities: "needed" (some quantity changes: Holm-adjusted paired t <= alpha over
    them, and not equivalent within its margin), "not needed" (every one within its margin by TOST at alpha / 2,
    the margin being the floor's lower confidence limit at 1 - alpha / 2: error rate at most alpha), or
    "undecided at n seeds" (n the most seeds a quantity paired); untested quantities keep their own verdict."""
    keys = [k for k, c in changes.items() if c is not None]
    testable = [k for k in keys if changes[k]["n"] >= 2 and changes[k]["p"] is not None]
    for k in keys:
        if k not in testable:
            changes[k]["verdict"] = "untested"
    if not testable:
        return "undetermined (fewer than 2 paired seeds)" if keys else "undetermined (no values)"
    adjusted, _ = stats.holm([changes[k]["p"] for k in testable], alpha)
    for k, a in zip(testable, adjusted):
        c = changes[k]
        c["p_holm"] = a
        equivalent = c["p_tost"] is not None and c["p_tost"] <= alpha / 2.0
        c["verdict"] = ("within margin" if equivalent else
                        "changes" if a is not None and a <= alpha else "undecided")
    verdicts = [changes[k]["verdict"] for k in testable]
    n = max(changes[k]["n"] for k in testable)
    if "changes" in verdicts:
        return "needed"
    if all(v == "within margin" for v in verdicts):
        return "not needed"
    return f"undecided at {n} seeds"


def analyse(root, deck_path, deck, configs, seeds, scene, margin_floors=MARGIN_FLOORS, alpha=ALPHA):
    """The result dict of the runs under `root` (sufficiency.json)."""
    runs, samples, failed = {}, [], []
    for s in build_plan(deck, configs, seeds):
        entry = run_entry(root, s, scene["end_strain"])
        if s["kind"] == "sample":
            samples.append(entry)
        elif entry["rc"] != 0:
            failed.append(s["name"])
        else:
            runs.setdefault(s["group"], []).append(entry)
    quantities = quantities_of(deck)
    base_runs = runs.get("baseline", [])
    mean, floor = noise_floor([r["metrics"] for r in base_runs], quantities)
    rows = [switch_row(config, runs, floor, quantities, deck, margin_floors, alpha) for config in configs]
    uncontrolled = sorted(f"{r['name']}: {t}" for rs in runs.values() for r in rs for t in r["excluded"])
    no_peak = sorted(f"{r['name']}: {t}" for rs in runs.values() for r in rs for t in r.get("no_peak", []))
    return {"deck": deck_path, "scene": scene, "seeds": list(seeds), "alpha": alpha, "margin_floors": margin_floors,
            "margin_level": 1.0 - alpha / 2.0, "tost_alpha": alpha / 2.0,
            "power": POWER, "uncontrolled": uncontrolled, "no_peak": no_peak,
            "quantities": [f"{t}.{q}" for t, q in quantities],
            "summary_fields": SUMMARY_TEXT,
            "noise_floor": {f"{t}.{q}": {"mean": mean[(t, q)], "std": floor[(t, q)]} for t, q in quantities},
            "mean_contact": configs[0][3].get("mean_contact"), "rows": rows, "samples": samples,
            "failed": failed, "cost": cost_of(root, runs, samples)}


def run_entry(root, s, end_strain):
    """One run of the plan as the analysis reads it: its outcome, and for a sample its packing; for a test run that
    finished its metrics (less its uncontrolled tests, and the peak quantities of tests that reached no peak), the
    tests whose peak plateau reaches the end, and the contact law."""
    d = study_runs.run_dir(root, s)
    out = study_runs.outcome(root, s)
    entry = {"name": s["name"], "seed": s["seed"], "rc": None if out is None else out.get("rc"),
             "cpu_s": None if out is None else out.get("cpu_s"),
             "wall_s": None if out is None else out.get("wall_s")}
    summary = read_json(os.path.join(d, "summary.json")) or {}
    if s["kind"] == "sample":
        prep = summary.get("prepared") or {}
        entry.update(void_ratio=number(prep.get("void_ratio")), Z=number(prep.get("Z")),
                     steps=prep.get("steps"))
        return entry
    if entry["rc"] != 0:
        return entry
    entry["metrics"] = run_metrics(summary, end_strain)
    # tests whose control failed (summary.json "controlled": false) are left out of the comparisons
    entry["excluded"] = {t: "uncontrolled" for t, info in (summary.get("tests") or {}).items()
                         if isinstance(info, dict) and info.get("controlled", True) is False}
    for t in entry["excluded"]:  # nor in the noise floor
        entry["metrics"].pop(t, None)
    entry["no_peak"] = [t for t, info in (summary.get("tests") or {}).items()
                        if isinstance(info, dict) and info.get("peak_reached", True) is False]
    for t in entry["no_peak"]:  # no peak reached: no peak quantities
        for q in PEAK_QUANTITIES:
            entry["metrics"].get(t, {}).pop(q, None)
    entry["peak_at_end"] = {}
    for test, info in (summary.get("tests") or {}).items():
        plateau = (info.get("peak_robust") or {}).get("plateau_e1") if isinstance(info, dict) else None
        final = number(info.get("final_e1")) if isinstance(info, dict) else None
        if plateau and final is not None:
            entry["peak_at_end"][test] = plateau[1] >= final * (1 - 1e-9)
    entry["contact_law"] = (summary.get("settings") or {}).get("contact_law")
    return entry


def metric_values(rs, q):
    """The runs' values of quantity q = (test, quantity), those they have."""
    return [r["metrics"].get(q[0], {}).get(q[1]) for r in rs if r["metrics"].get(q[0], {}).get(q[1]) is not None]


def metric_by_seed(rs, q):
    """{seed: value} of quantity q = (test, quantity) over the runs that have it."""
    return {r["seed"]: r["metrics"][q[0]][q[1]] for r in rs
            if r["metrics"].get(q[0], {}).get(q[1]) is not None}


def switch_row(config, runs, floor, quantities, deck, margin_floors, alpha):
    """One configuration's row: its seeds, cost, seed means and, for a switch, each quantity's paired change
    from the baseline and the verdict."""
    key, label, vdeck, info = config
    row = {"key": key, "label": label, "info": info}
    if vdeck is None:
        row["verdict"] = info["skipped"]
        return row
    rs, base_runs = runs.get(key, []), runs.get("baseline", [])
    row["seeds"] = sorted(r["seed"] for r in rs)
    row["cpu_s"] = sum(r["cpu_s"] or 0.0 for r in rs)
    row["contact_law"] = rs[0]["contact_law"] if rs else None
    row["peak_at_end"] = {t: sum(1 for r in rs if r["peak_at_end"].get(t)) for t in deck_tests(deck)}
    row["seed_means"] = {f"{t}.{q}": (describe(metric_values(rs, (t, q))) or {}).get("mean") for t, q in quantities}
    if key != "baseline":
        row["changes"] = {f"{t}.{q}": change(paired(metric_by_seed(base_runs, (t, q)), metric_by_seed(rs, (t, q))),
                                             floor[(t, q)], len(quantities), margin_floors, alpha,
                                             floor_n=len(metric_values(base_runs, (t, q))))
                          for t, q in quantities}
        row["verdict"] = judge_switch(row["changes"], alpha)
        row["needed_for"] = [k for k, c in row["changes"].items() if c and c["verdict"] == "changes"]
        if not rs:
            row["verdict"] = "not run"
    return row


def cost_of(root, runs, samples):
    """The CPU and wall time of every run and sample, and of the invocations (timing.json)."""
    timing = read_json(os.path.join(root, "timing.json")) or {"invocations": []}
    all_runs = [r for rs in runs.values() for r in rs] + samples
    return {"cpu_s": sum(r["cpu_s"] or 0.0 for r in all_runs),
            "run_wall_s": sum(r["wall_s"] or 0.0 for r in all_runs),
            "runs": len(all_runs), "invocations": timing["invocations"],
            "wall_s": sum(i["wall_s"] for i in timing["invocations"])}


def deck_tests(deck):
    return [t["name"] for t in deck.get("tests", [])]


# ---- the report ----------------------------------------------------------------------------------------------

def quantity_label(key):
    test, q = key.split(".")
    return f"{test.upper()} {QUANTITY_LABELS.get(q, q)}" + (" (%)" if q in PERCENT else "")


def scaled_value(key, v):
    return None if v is None else v * (100.0 if key.split(".")[1] in PERCENT else 1.0)


def cell(c, key):
    """'0.012 (+0.45 fl.; p 0.03, Holm 0.2; ≥ 0.9 fl.) ✗': Δ, Δ in noise floors, the paired t's p and its Holm
    adjustment, the smallest change detectable at 80 % power in floors; ✗ a change, ≈ within the margin."""
    if c is None:
        return "n/a"
    if c["noise_units"] is None:
        return f"{fmt(scaled_value(key, c['delta']))} (no noise floor)"
    mark = {"changes": " **✗**", "within margin": " ≈",
            "untested": f" (untested: {c['n']} seed{'s' if c['n'] != 1 else ''})"}.get(c.get("verdict"), "")
    det = "n/a" if c["detectable"] is None else f"{c['detectable'] / c['floor']:.2f}"
    p = "n/a" if c["p"] is None or c["p_holm"] is None else f"{c['p']:.2g}, Holm {c['p_holm']:.2g}"
    return f"{fmt(scaled_value(key, c['delta']))} ({c['noise_units']:+.2f} fl.; p {p}; detects {det} fl.){mark}"


def markdown(result, heading="#"):
    """sufficiency.md: the scene and how to read the cells, the table of switches, and the notes."""
    out = intro_lines(result, heading) + [md_table(*switch_table(result)), ""]
    return "\n".join(out + notes_lines(result) + [""])


def intro_lines(result, heading):
    """The heading, the reduced scene, the switches' linear equivalents and how the cells and verdicts read."""
    sc = result["scene"]
    cm = result.get("mean_contact") or {}
    qs = result["quantities"]
    # results written before the margin carried the floor's uncertainty have no margin_level
    margin_level = result.get("margin_level", 1.0 - result["alpha"] / 2.0)
    tost_alpha = result.get("tost_alpha", result["alpha"] / 2.0)
    ks = sorted({c["floor_n"] for r in result["rows"] for c in (r.get("changes") or {}).values()
                 if c and (c.get("floor_n") or 0) >= 2}) or [len(result["seeds"])]
    margin_text = ", ".join(f"{float(equivalence_margin(result['margin_floors'], k, 1.0, margin_level)):.2f} of "
                            f"the estimated floor with {k} seeds" for k in ks) or "no floor"
    out = [f"{heading} Model sufficiency: {result['deck']}", ""]
    out += [f"Reduced scene: **{sc['count']} spheres** (the deck: {sc['deck_count']}), tests to "
            f"**ε1 = {sc['end_strain']:.1%}** (the deck: {', '.join(f'{x:.0%}' for x in sc['deck_end_strains'])}), "
            f"everything else the deck's; seeds {', '.join(str(s) for s in result['seeds'])}. Each seed's sample is "
            "prepared once with the deck (frictionless preparation) and every configuration runs its tests from it, "
            "so a switch acts on the tests only (hertz → linear starts from a sample compressed with Hertz contacts, "
            "which the servo re-balances at the test's start; affine → lammps from one prepared with the affine "
            "term).",
            "",
            "Each row switches one sub-model or term one step simpler, the others as the deck has them." +
            (" Linear equivalents at the mean contact force "
             f"F = π d² p / {'n/a' if cm.get('z_phi') is None else format(cm['z_phi'], 'g')} = {fmt(cm.get('force'))} N "
             f"(d = {fmt(cm.get('mean_diameter') and cm['mean_diameter'] * 1e3)} "
             f"mm the mean diameter, p = {fmt(cm.get('pressure'))} Pa the confining stress), overlap δ = "
             f"{fmt(cm.get('overlap'))} m of two mean spheres (R* = d/4): kn = F/δ (secant), kt = 8 G* a, "
             "a = sqrt(R* δ). Contact-law switches keep the baseline's drag coefficients (damping fractions "
             "rescaled)." if any((r.get("info") or {}).get("set") for r in result["rows"]) else ""),
            "",
            f"Cells: Δ = the mean over the seeds of the paired difference variant − baseline on the same sample "
            f"(strains in %); in parentheses Δ in noise floors (fl.: the baseline's seed-to-seed std), the two-sided "
            f"p of the paired t-test (n − 1 dof) and its Holm adjustment over the switch's {len(qs)} quantities, and "
            f"the smallest change the seeds detect with {result['power'] * 100:g} % power at Holm's strictest level "
            f"α/{len(qs)} (noncentral t), in floors. **✗**: the quantity changes (Holm-adjusted p ≤ "
            f"{result['alpha']:g} and not within the margin); ≈: within the margin by two one-sided t-tests (TOST) at "
            f"{tost_alpha:g}, the margin being ±{result['margin_floors']:g} × the noise floor's lower "
            f"{margin_level * 100:g} % confidence limit s √(k / χ²({margin_level:g}, k)), k = the baseline's seeds − 1 "
            f"({margin_text}), since the floor is estimated from those few seeds. Verdicts: \"needed\" when some "
            f"quantity changes (family-wise error rate {result['alpha'] * 100:g} % per switch: a switch that changes "
            "nothing is called needed at most that often); \"not needed\" when every quantity is within the margin "
            f"(an intersection-union test; a true change of {result['margin_floors']:g} floor is called within the "
            f"margin at most {(1 - margin_level + tost_alpha) * 100:g} % of the time: "
            f"{(1 - margin_level) * 100:g} % that the limit exceeds the true floor plus {tost_alpha * 100:g} % for "
            "the TOST, a union bound; the simulation in tests/tools/test_sufficiency_stats.py measures 0.39 % with 4 "
            "seeds, paired-difference sd 0.2 floor, 100,000 trials, binomial 95 % interval 0.35–0.43 %; with the "
            "margin at the estimated floor itself it was 23 %); else \"undecided at n seeds\" (more seeds, or a "
            "detectable change below the margin, would decide). Quantities from summary.json: "
            + "; ".join(f"{k}: {v}" for k, v in result["summary_fields"].items()) + ".", ""]
    return out


def switch_table(result):
    """(headers, rows) of the table: the baseline's means and floors, then each switch's verdict and cells."""
    qs = result["quantities"]
    headers = ["switch", "seeds", "verdict"] + [quantity_label(k) for k in qs]
    rows = []
    for r in result["rows"]:
        if r["key"] == "baseline":
            rows.append(["baseline: mean (noise floor)", ",".join(map(str, r.get("seeds", []))), "—"] +
                        [f"{fmt(scaled_value(k, result['noise_floor'][k]['mean']))} "
                         f"({fmt(scaled_value(k, result['noise_floor'][k]['std']))})" for k in qs])
            continue
        if "changes" not in r:
            rows.append([r["label"], "—", r["verdict"]] + ["—"] * len(qs))
            continue
        rows.append([r["label"], ",".join(map(str, r["seeds"])), r["verdict"]] +
                    [cell(r["changes"].get(k), k) for k in qs])
    return headers, rows


def notes_lines(result):
    """The notes under the table: each switch's set values, late peaks, failed and uncontrolled runs, the cost."""
    cost = result["cost"]
    notes = []
    for r in result["rows"]:
        info = r.get("info") or {}
        set_ = info.get("set") or {}
        f = info.get("damping_factors") or {}
        bits = [f"{k} = {fmt(v)} N/m" for k, v in set_.items()]
        bits += [f"{k} damping × {fmt(x)} (→ {fmt(info['damping'][k])})" for k, x in f.items() if x != 1.0]
        if bits:
            notes.append(f"- {r['label']}: " + ", ".join(bits) + ".")
    late = [f"{r['key']} {t.upper()} {n}/{len(r['seeds'])}" for r in result["rows"]
            for t, n in (r.get("peak_at_end") or {}).items() if n]
    if late:
        notes.append("- Seeds whose robust peak plateau reaches the reduced test's end (the peak may lie beyond it; "
                     "its ε1 is then the end's): " + ", ".join(late) + ".")
    if result["failed"]:
        notes.append(f"- Failed runs (left out): {', '.join(result['failed'])}.")
    if result.get("uncontrolled"):
        notes.append(f"- Tests whose control failed (left out of the comparisons): {', '.join(result['uncontrolled'])}.")
    if result.get("no_peak"):
        notes.append(f"- Tests that reached no peak (their peak quantities left out): {', '.join(result['no_peak'])}.")
    waits = cost["invocations"]
    notes.append(f"- Cost: {cost['runs']} runs ({len(result['samples'])} preparations), "
                 f"{fmt(cost['cpu_s'], 0)} CPU s in all; wall {fmt(cost['wall_s'], 0)} s with "
                 f"{', '.join(str(i['jobs']) for i in waits) or 'n/a'} runs at a time"
                 f"{' over ' + str(len(waits)) + ' invocations' if len(waits) > 1 else ''}.")
    return notes


def write(root, result):
    study_runs.write_json(os.path.join(root, "sufficiency.json"), result)
    path = os.path.join(root, "sufficiency.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write(markdown(result))
    return path


def study_section(study_root):
    """The "Model sufficiency" section of the study's report: sufficiency.md of each folder named sufficiency*
    beside the study root or inside it, headings one level down; [] when there is none."""
    found = []
    for base in (os.path.dirname(os.path.abspath(study_root)), os.path.abspath(study_root)):
        if not os.path.isdir(base):
            continue
        for name in sorted(os.listdir(base)):
            path = os.path.join(base, name, "sufficiency.md")
            if name.startswith("sufficiency") and os.path.isfile(path):
                found.append(path)
    if not found:
        return []
    out = ["## Model sufficiency", "",
           "`tools/sufficiency.py DECK --out DIR`: each sub-model or term of a deck switched one step simpler, one "
           "at a time, on a reduced scene over several seeds; a paired t-test per quantity with Holm's adjustment "
           "over the switch's quantities marks the sub-model as needed, equivalence within a noise floor (TOST) as "
           "not needed. Included from:", ""]
    out += [f"- `{os.path.relpath(p, study_root)}`" for p in found] + [""]
    for p in found:
        with open(p, encoding="utf-8") as f:
            text = f.read()
        out += [("#" * 2 + line) if line.startswith("#") else line for line in text.splitlines()] + [""]
    return out
