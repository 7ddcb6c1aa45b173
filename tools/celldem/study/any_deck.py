"""The speed–accuracy study on any deck (tools/study.py plan|run|analyse --deck DECK --budget-core-hours H).

The scene is the deck itself, its law, paths and tests, with fewer spheres (`count`, 1000 by default, never more
than the deck's). The knob is the deck's own loading rate: each setting runs every test at `factor` times it (the
strain increments and rates of the strain-driven axes and the rates of stress ramps; a leg that ends on a step
count gets 1/factor of its steps, so that it covers the same strain; the output interval shrinks alike, so the
rows per strain stay the same; a deck's servo.max_strain_increment, when given, grows with it). Factor 1 is the
reference: the deck as written.

Every setting is a seed ensemble of the same seeds (`celldem run --seeds 1-n`, one thread), preparation
included, so the reference's seed-to-seed spread is the deck's own noise floor, measured at its own settings;
a setting's error is the comparison of its ensemble with the reference's (celldem.study.compare: per summary
quantity the mean paired difference in floors, paired t and TOST), summed up as its largest |mean difference| in
floors. How many settings and seeds fit the budget comes from `celldem plan --json`'s particle-steps of each
setting's deck (the preparation's as the middle of its range) and a throughput in particle-steps per core-second
(measured by an earlier run of the study when there is one, else `celldem plan`'s stated figure, else the
one given).

Layout under ROOT/<deck name>/: study_plan.json (the choice and its arithmetic), rate_x<factor>/deck.json and the
ensemble celldem writes beside it, and after analyse study.md, study.json and pareto.png.
"""

import copy
import json
import os
import subprocess

from .. import binary
from ..files import load_json
from . import compare as study_compare

DEFAULT_COUNT = 1000
# The settings in the order they are dropped last to first when the budget is short: the reference, then rates
# that bracket where a deck usually leaves the quasi-static regime, then the extremes.
RATE_FACTORS = (1.0, 4.0, 2.0, 8.0, 16.0, 32.0)
MIN_SEEDS, MAX_SEEDS = 3, 8
STRAIN_DRIVEN = ("strain_increment", "strain_rate")


class StudyError(Exception):
    """A deck or budget the study cannot work with (the message says what to change)."""


def _legs(test):
    """Every leg dict of a test (the one-leg form is the test itself), blocks of `repeat` included."""
    if "legs" not in test:
        return [test]
    out = []
    for leg in test["legs"]:
        out.extend(_legs(leg) if "repeat" in leg else [leg])
    return out


def scene(deck, count=DEFAULT_COUNT):
    """The reduced scene of a deck: a copy with at most `count` spheres. A deck that starts from a state file has
    no seeds to vary: refused."""
    if "initial_state" in deck:
        raise StudyError("the deck starts from initial_state: a study needs samples that differ by seed (give it a "
                         "deck that prepares its own sample)")
    out = copy.deepcopy(deck)
    out["sample"]["count"] = min(int(deck["sample"]["count"]), int(count))
    return out


def with_rate(deck, factor):
    """The deck with every test driven `factor` times faster (see the module's doc)."""
    out = copy.deepcopy(deck)
    for test in out.get("tests", []):
        for leg in _legs(test):
            for axis in (leg.get("axes") or {}).values():
                for key in STRAIN_DRIVEN:
                    if key in axis:
                        axis[key] *= factor
                if "stress_ramp" in axis and "rate" in axis["stress_ramp"]:
                    axis["stress_ramp"]["rate"] *= factor
            end = leg.get("end") or {}
            for key in ("steps", "max_steps"):
                if key in end and end[key]:
                    end[key] = max(1, int(round(end[key] / factor)))
        if "output_interval" in test:
            test["output_interval"] = max(1, int(round(test["output_interval"] / factor)))
        elif factor != 1.0:
            test["output_interval"] = max(1, int(round(1000 / factor)))  # celldem's default, scaled
    servo = out.get("servo") or {}
    if "max_strain_increment" in servo:
        servo["max_strain_increment"] *= factor
    return out


def predicted_particle_steps(plan):
    """Particle-steps of one run of a deck from its `celldem plan --json`: the tests' as planned, the
    preparation's as the middle of its range (its length is known only by running)."""
    e = plan["estimate"]
    high = e.get("particle_steps_high")
    low = e["particle_steps_low"]
    return 0.5 * (low + high) if high is not None and high >= 0 else 2.0 * low


def choose(costs, budget_core_hours, throughput):
    """The largest study that fits: `costs` {factor: particle-steps of one seed} in RATE_FACTORS order, the budget
    in core-hours and the throughput in particle-steps per core-second. Prefers settings to seeds down to
    MIN_SEEDS; returns {"factors", "seeds", "core_hours"}; StudyError when not even the reference and one
    setting on MIN_SEEDS seeds fit."""
    budget = budget_core_hours * 3600.0 * throughput  # particle-steps
    factors = [f for f in RATE_FACTORS if f in costs]
    for k in range(len(factors), 1, -1):
        per_seed = sum(costs[f] for f in factors[:k])
        seeds = min(MAX_SEEDS, int(budget // per_seed))
        if seeds >= MIN_SEEDS:
            return {"factors": factors[:k], "seeds": seeds,
                    "core_hours": seeds * per_seed / throughput / 3600.0}
    need = MIN_SEEDS * sum(costs[f] for f in factors[:2]) / throughput / 3600.0
    raise StudyError(f"the budget of {budget_core_hours:g} core-hours is too small: the smallest study (the deck and "
                     f"one faster setting on {MIN_SEEDS} seeds) needs about {need:.3g} (or fewer spheres: --count)")


def setting_dir(root, factor):
    return os.path.join(root, f"rate_x{factor:g}")


def measured_throughput(root):
    """Particle-steps per core-second of the study's runs so far (their summaries: steps × particles over wall
    time, one thread each), None before any."""
    steps = wall = 0.0
    for factor in RATE_FACTORS:
        try:
            seeds = study_compare.load_seeds(os.path.join(setting_dir(root, factor), "ensemble"))
        except study_compare.CompareError:
            continue
        for summary in seeds.values():
            s, w = study_compare.cost(summary)
            steps, wall = steps + s, wall + w
    return steps / wall if wall > 0 else None


def plan_study(deck_path, root, budget_core_hours, celldem, count=DEFAULT_COUNT, throughput=None):
    """Writes each setting's deck and ROOT/study_plan.json; returns the plan."""
    deck = load_json(deck_path)
    base = scene(deck, count)
    costs, plans = {}, {}
    os.makedirs(root, exist_ok=True)
    for factor in RATE_FACTORS:
        d = with_rate(base, factor)
        folder = setting_dir(root, factor)
        os.makedirs(folder, exist_ok=True)
        with open(os.path.join(folder, "deck.json"), "w", encoding="utf-8") as f:
            json.dump(d, f, indent=1)
        plans[factor] = binary.plan(os.path.join(folder, "deck.json"), celldem)
        costs[factor] = predicted_particle_steps(plans[factor])
    source = "given"
    if throughput is None:
        throughput, source = measured_throughput(root), "measured by this study's runs so far"
    if throughput is None:
        throughput = plans[1.0]["estimate"]["particle_steps_per_core_second"]
        source = "celldem plan's stated figure (particle_steps_per_core_second)"
    choice = choose(costs, budget_core_hours, throughput)
    # Every setting on MAX_SEEDS with budget to spare: the spheres the budget would allow (cost ~ spheres), up to
    # the deck's own count, for the user to ask for with --count.
    if len(choice["factors"]) == len(RATE_FACTORS) and choice["seeds"] == MAX_SEEDS:
        affordable = int(base["sample"]["count"] * budget_core_hours / choice["core_hours"])
        choice["affordable_count"] = min(int(deck["sample"]["count"]), affordable)
    result = {"deck": os.path.abspath(deck_path), "count": base["sample"]["count"],
              "budget_core_hours": budget_core_hours, "throughput": throughput, "throughput_source": source,
              "predicted_particle_steps": {f"{f:g}": costs[f] for f in RATE_FACTORS},
              "inertial_number": {f"{f:g}": [t.get("inertial_number") for t in plans[f]["tests"]] for f in RATE_FACTORS},
              **choice}
    with open(os.path.join(root, "study_plan.json"), "w", encoding="utf-8") as f:
        json.dump(result, f, indent=1)
    return result


def run_study(root, plan, celldem, runner=subprocess.run):
    """Runs each chosen setting's ensemble that is not complete (its ensemble.json missing), one thread each. A
    setting whose run fails (too fast to stay quasi-static, say) is recorded in its failed.json and the others go
    on; the reference must not fail."""
    for factor in plan["factors"]:
        folder = setting_dir(root, factor)
        if os.path.exists(os.path.join(folder, "ensemble", "ensemble.json")):
            continue
        cmd = [celldem, "run", os.path.join(folder, "deck.json"), "--out", os.path.join(folder, "ensemble"),
               "--seeds", f"1-{plan['seeds']}", "--threads", "1", "--quiet", "--force"]
        done = runner(cmd, capture_output=True, text=True)
        if done.returncode != 0:
            if factor == 1.0:
                raise StudyError(f"the deck as written failed: {' '.join(cmd)}: exit {done.returncode}: "
                                 f"{done.stderr[-1000:]}")
            with open(os.path.join(folder, "failed.json"), "w", encoding="utf-8") as f:
                json.dump({"command": cmd, "rc": done.returncode, "stderr": done.stderr[-4000:]}, f, indent=1)


def analyse_study(root, plan):
    """The comparison of every setting with the reference: rows {factor, error (largest |floors|), worst
    quantity, equivalent (every quantity's TOST verdict), cpu_s, particle_steps, comparison}."""
    reference = os.path.join(setting_dir(root, 1.0), "ensemble")
    rows = []
    for factor in plan["factors"]:
        other = os.path.join(setting_dir(root, factor), "ensemble")
        failed = os.path.join(setting_dir(root, factor), "failed.json")
        if os.path.exists(failed):
            why = load_json(failed)["stderr"].strip().splitlines()
            rows.append({"factor": factor, "error": None, "worst": "failed: " + (why[-1] if why else "?"),
                         "equivalent": None, "cpu_s": None, "particle_steps": None, "comparison": None})
            continue
        result = study_compare.compare(reference, other)
        tested = [q for q in result["quantities"] if q["floors"] is not None]
        worst = max(tested, key=lambda q: abs(q["floors"])) if tested else None
        rows.append({"factor": factor, "error": abs(worst["floors"]) if worst else None,
                     "worst": worst["label"] if worst else None,
                     "equivalent": all(q["verdict"] == "equivalent" for q in tested) if tested else None,
                     "cpu_s": result["cost"]["other_wall_s"], "particle_steps": result["cost"]["other_particle_steps"],
                     "comparison": result})
    return rows


def draw(rows, path):
    """Error in floors against single-thread CPU time, one point per setting."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for r in rows:
        if r["error"] is None or r["cpu_s"] is None:
            continue
        ax.plot(r["cpu_s"], r["error"], "o", color="C0" if r["factor"] != 1.0 else "k")
        ax.annotate(f"×{r['factor']:g}", (r["cpu_s"], r["error"]), textcoords="offset points", xytext=(4, 4))
    ax.axhline(1.0, color="grey", linestyle="--", label="1 noise floor")
    ax.set_xscale("log")
    ax.set_xlabel("CPU time of the ensemble (s, one thread per run)")
    ax.set_ylabel("largest |mean paired difference| (floors)")
    ax.set_title("error against run time, by loading rate")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_report(root, plan, rows):
    """study.md (the plan's arithmetic, one row per setting, each setting's full comparison), study.json and
    pareto.png under root; returns their paths."""
    figure = draw(rows, os.path.join(root, "pareto.png"))
    lines = [f"# Speed–accuracy study of {plan['deck']}", "",
             f"{plan['count']} spheres, {plan['seeds']} seeds, loading rate × {', '.join(f'{f:g}' for f in plan['factors'])} "
             f"(× 1: the deck as written); chosen for a budget of {plan['budget_core_hours']:g} core-hours at "
             f"{plan['throughput']:.3g} particle-steps per core-second ({plan['throughput_source']}): about "
             f"{plan['core_hours']:.3g} core-hours predicted.", "",
             "| rate | error (floors) | worst quantity | every quantity within ±1 floor (TOST) | CPU s | particle-steps |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        err = "—" if r["error"] is None else f"{r['error']:.2f}"
        eq = "—" if r["equivalent"] is None else ("yes" if r["equivalent"] else "no")
        cpu = "—" if r["cpu_s"] is None else f"{r['cpu_s']:.4g}"
        steps = "—" if r["particle_steps"] is None else f"{r['particle_steps']:.3g}"
        lines.append(f"| × {r['factor']:g} | {err} | {r['worst'] or '—'} | {eq} | {cpu} | {steps} |")
    lines += ["", f"![error against run time]({os.path.basename(figure)})", ""]
    for r in rows:
        if r["factor"] != 1.0 and r["comparison"] is not None:
            lines += [f"## × {r['factor']:g} against the deck as written", "", study_compare.markdown(r["comparison"]), ""]
    md = os.path.join(root, "study.md")
    with open(md, "w", encoding="utf-8") as f:
        f.write("\n".join(lines))
    js = os.path.join(root, "study.json")
    with open(js, "w", encoding="utf-8") as f:
        json.dump({"plan": plan, "settings": rows}, f, indent=1)
    return md, js, figure


def default_root(deck_path):
    """results/study-<deck name>/ of the repository."""
    return os.path.join(binary.REPO, "results", "study-" + os.path.splitext(os.path.basename(deck_path))[0])


def read_plan(root):
    path = os.path.join(root, "study_plan.json")
    if not os.path.exists(path):
        raise StudyError(f"no {path}: run `tools/study.py plan --deck DECK --budget-core-hours H` first")
    plan = load_json(path)
    plan["factors"] = [float(f) for f in plan["factors"]]
    return plan

