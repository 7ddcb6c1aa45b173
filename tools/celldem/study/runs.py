"""The study's runs (tools/study.py plan and run): which runs, their decks (the paper deck with values
changed), running celldem on them one at a time (resumable), and writing the presets' decks.

Each run folder holds deck.json, spec.json (what the run varies), plan.json (`celldem plan deck.json --json`:
steps, the critical time step, the inertial number; the analysis reads it instead of deriving them),
outcome.json (exit code, CPU and wall time) and celldem's own outputs.
"""

import copy
import hashlib
import json
import math
import os
import signal
import socket
import subprocess
import sys
import time

from .. import binary, decks
from ..results import read_json
from .analysis import rules_levels
from .scene import (END_STRAIN, PAPER_DAMPING, PAPER_DT, PAPER_INC, PAPER_RATE, REF_SEEDS, ROW_STRAIN,
                          SCENE_COUNT, SERVO_CAP_FACTOR, SERVO_INC, SERVO_OUTPUT_INTERVAL, SERVO_STRAIN,
                          STABILITY_STRAIN)

DEFAULT_ROOT = os.path.join(binary.REPO, "results", "study")
SAMPLE_STEPS_ESTIMATE = 160_000   # steps of a sample's preparation, for the cost estimate (known only by running)


# ---- the plan: which runs ----------------------------------------------------------------------------------

def sample_name(count=SCENE_COUNT, seed=1, time_step=PAPER_DT, servo_cap=None):
    name = f"n{count}_s{seed}"
    name = name if time_step == PAPER_DT else f"{name}_dt{time_step:g}"
    return name if servo_cap is None else f"{name}_cap{servo_cap:g}"


def sample_spec(count=SCENE_COUNT, seed=1, time_step=PAPER_DT, priority=0, label=None, servo_cap=None):
    """A preparation with the paper's settings; time_step and servo.max_strain_increment (servo_cap) as a preset
    deck would change them (its preparation runs with its own time step and servo)."""
    cap = "" if servo_cap is None else f", servo.max_strain_increment {servo_cap:g}"
    return {"name": sample_name(count, seed, time_step, servo_cap), "kind": "sample", "group": "sample",
            "label": label or f"{count} spheres, seed {seed}, dt {time_step:g} s{cap}", "count": count, "seed": seed,
            "time_step": time_step, "servo_cap": servo_cap, "priority": priority}


def test_spec(name, group, label, priority, *, seed=1, count=SCENE_COUNT, sample_dt=PAPER_DT, sample_cap=None,
              time_step=PAPER_DT,
              strain_increment=PAPER_INC, density_factor=1.0, damping=(PAPER_DAMPING, PAPER_DAMPING),
              row_strain=ROW_STRAIN, output_interval=None, tests=("ttc", "psc"), end_strain=END_STRAIN,
              contact=None, kinematics=None, servo=None, role="accuracy", knob=None, value=None):
    interval = output_interval or max(1, int(round(row_strain / strain_increment)))
    if servo is None and strain_increment != PAPER_INC:
        # The servo may move a stress-controlled axis by at most max_strain_increment per step. PSC's free axis
        # moves about 2 × Δε1 per step once the sample dilates, so the cap must grow with Δε1: 5 × Δε1, which is
        # the paper's own ratio (1e-6 = 5 × 2e-7). The servo_cap group shows what happens without it.
        servo = {"max_strain_increment": SERVO_CAP_FACTOR * strain_increment}
    return {"name": name, "kind": "test", "group": group, "label": label, "role": role, "priority": priority,
            "knob": knob, "value": value, "sample": sample_name(count, seed, sample_dt, sample_cap),
            "sample_dt": sample_dt, "sample_cap": sample_cap,
            "count": count,
            "seed": seed, "time_step": time_step, "strain_increment": strain_increment,
            "density_factor": density_factor, "damping": list(damping), "output_interval": interval,
            "tests": list(tests), "end_strain": end_strain, "contact": contact or {}, "kinematics": kinematics,
            "servo": servo}


MORE_SEEDS = ("inc_5e-07", "inc_1e-06", "dt_2e-06", "dt_3e-06", "combo_dt3e-06_inc1.5e-06", "combo_dt3e-06_inc1e-06",
              "combo_dt2e-06_inc8e-07", "model_project", "model_radius", "model_rotdamp0", "model_lammps")


def build_plan(tc):
    """Every run of the study, in order of importance (priority, then as listed); tc: sqrt(m_min/kn) of the paper
    deck [s] (`celldem plan` normal_time_step), which places the time steps of the stability map."""
    plan = reference_specs() + setting_specs(tc) + other_knob_specs() + modelling_specs()
    plan += stability_specs(tc) + preparation_specs(tc) + count_specs()
    plan += more_seed_specs(plan)
    order = {id(s): i for i, s in enumerate(plan)}
    return sorted(plan, key=lambda s: (s["priority"], order[id(s)]))


SEEDS12 = (1, 2)  # the seeds a setting runs on (MORE_SEEDS: 3 and 4 too)


def reference_specs():
    """The reference samples, the paper's settings on each, and the round-off level."""
    plan = []
    # Samples: the reference seeds first; the others when their runs come up. Seeds 5-8 only sharpen the noise
    # floor (a standard deviation from 4 samples is uncertain by a factor of 2); settings are run on seeds 1-4.
    for seed in REF_SEEDS:
        plan.append(sample_spec(seed=seed, priority=0 if seed <= 4 else 6))
    # The reference: the paper's settings on each reference sample.
    for seed in REF_SEEDS:
        plan.append(reference_spec(seed, 1 if seed <= 4 else 6))
    # The round-off level: the paper's settings with dt changed in its 9th digit. DEM is chaotic, so this alone
    # sends each run down another path; its differences from the reference are what a perfect setting scores.
    for seed in (1, 2, 3, 4):
        plan.append(test_spec(f"null_s{seed}", "null", "paper settings, dt × (1 + 1e-9): round-off only", 2,
                              seed=seed, time_step=PAPER_DT * (1 + 1e-9), knob="null", value=seed))
    return plan


def reference_spec(seed, priority=1):
    """The reference run of one seed: the paper's settings on that seed's reference sample (sample_spec(seed=seed)),
    its TTC and PSC to END_STRAIN."""
    return test_spec(f"ref_s{seed}", "reference", f"paper settings, seed {seed}", priority, seed=seed,
                     role="reference", knob="reference", value=seed)


def setting_specs(tc):
    """The knobs that trade accuracy for speed: the strain increment, the time step, density scaling, and the
    combinations of a larger time step with a larger rate (the presets' candidates)."""
    plan = []
    # Knob 1: axial strain increment per step at the paper's dt (the strain rate rises with it).
    for inc, seeds, prio in ((5e-7, SEEDS12, 2), (1e-6, SEEDS12, 2), (2e-6, SEEDS12, 2), (5e-6, SEEDS12, 2),
                             (1e-5, SEEDS12, 2), (2e-5, SEEDS12, 3), (5e-5, SEEDS12, 3), (1e-4, SEEDS12, 3),
                             (1e-7, (1,), 10)):
        for seed in seeds:
            plan.append(test_spec(f"inc_{inc:g}_s{seed}", "strain_increment", f"Δε1 = {inc:g}/step", prio,
                                  seed=seed, strain_increment=inc, knob="strain_increment", value=inc))
    # Knob 2: time step at the paper's strain rate (so the strain per step grows with dt).
    for frac_dt in (2e-6, 3e-6, 4e-6, 5e-6):
        for seed in SEEDS12:
            plan.append(test_spec(f"dt_{frac_dt:g}_s{seed}", "time_step", f"dt = {frac_dt / tc:.2f} t_c",
                                  3, seed=seed, time_step=frac_dt, strain_increment=PAPER_RATE * frac_dt,
                                  knob="time_step", value=frac_dt))
    # Knob 3: density scaling ×f with dt ×sqrt(f) (the critical step grows by sqrt(f)), at the paper's rate.
    for factor in (10.0, 100.0):
        dt = PAPER_DT * math.sqrt(factor)
        for seed in SEEDS12:
            plan.append(test_spec(f"density_x{factor:g}_s{seed}", "density",
                                  f"density ×{factor:g}, dt ×{math.sqrt(factor):.3g}",
                                  3, seed=seed, time_step=dt, strain_increment=PAPER_RATE * dt,
                                  density_factor=factor, knob="density_factor", value=factor))
    # Combinations of a larger dt with a larger strain rate: the candidates for the presets.
    for dt, inc in ((3e-6, 1.5e-6), (3e-6, 3e-6), (3e-6, 6e-6), (5e-6, 2.5e-6), (5e-6, 5e-6), (5e-6, 1e-5),
                    (3e-6, 1e-6), (2e-6, 8e-7)):
        for seed in SEEDS12:
            plan.append(test_spec(f"combo_dt{dt:g}_inc{inc:g}_s{seed}", "combined",
                                  f"dt = {dt / tc:.2f} t_c, Δε1 = {inc:g}", 4, seed=seed, time_step=dt,
                                  strain_increment=inc, knob="combined", value=inc))
    return plan


def other_knob_specs():
    """The damping fraction and the output interval."""
    plan = []
    # Knob 4: damping fraction (translational and rotational together).
    for alpha in (0.02, 0.1, 0.2):
        plan.append(test_spec(f"damping_{alpha:g}_s1", "damping", f"damping {alpha:g}", 5,
                              damping=(alpha, alpha), knob="damping", value=alpha))
    # Knob 5: output interval (rows cost a measurement each).
    for interval in (100, 10000):
        plan.append(test_spec(f"output_{interval}_s1", "output_interval", f"a row every {interval} steps", 5,
                              output_interval=interval, knob="output_interval", value=interval))
    return plan


def modelling_specs():
    """The modelling choices: TTC only, each against the reference on the same sample."""
    plan = []
    # Modelling choices: TTC only, each against the reference on the same sample.
    for key, (label, kw) in {
        "project": ("tangential_rotation project", {"contact": {"tangential_rotation": "project"}}),
        "radius": ("moment_arm radius", {"contact": {"moment_arm": "radius"}}),
        "rotdamp0": ("rotational damping 0", {"damping": (PAPER_DAMPING, 0.0)}),
        "lammps": ("kinematics lammps", {"kinematics": "lammps"}),
    }.items():
        for seed in SEEDS12:
            plan.append(test_spec(f"model_{key}_s{seed}", "modelling", label, 6, seed=seed, tests=("ttc",),
                                  role="modelling", knob="modelling", value=key, **kw))
    return plan


def stability_specs(tc):
    """The stability map: time step × damping, and the servo gains."""
    plan = []
    # Stability map 1: time step (fraction of t_c) × damping, short TTC at the paper's strain rate. celldem now
    # refuses (exit 2) a time step above the smallest limit over the contact modes, 0.5345 t_c with kt = kn.
    for alpha in (0.05, 0.01, 0.0):
        for frac in (PAPER_DT / tc, 0.3, 0.4, 0.5, 0.55, 0.6, 0.65, 0.8, 0.9, 0.999):
            if alpha != PAPER_DAMPING and frac in (0.4, 0.55, 0.6):
                continue
            dt = PAPER_DT if frac == PAPER_DT / tc else frac * tc
            plan.append(test_spec(f"stab_f{frac:.3g}_a{alpha:g}", "stability_dt",
                                  f"dt = {frac:.2f} t_c, damping {alpha:g}",
                                  7, time_step=dt, strain_increment=PAPER_RATE * dt, damping=(alpha, alpha),
                                  row_strain=ROW_STRAIN / 4, tests=("ttc",), end_strain=STABILITY_STRAIN,
                                  role="stability", knob="dt_fraction", value=frac))
    # Stability map 2: servo gains, short TTC at 2.5× the paper's rate, a row every 25 steps.
    for gain in (0.0, 0.01, 0.05, 0.2, 0.5, 1.0):
        for igain in (0.0, 0.002, 0.02, 0.1):
            if gain == 0.0 and igain == 0.0:
                continue
            plan.append(test_spec(f"servo_g{gain:g}_i{igain:g}", "stability_servo",
                                  f"gain {gain:g}, integral {igain:g}",
                                  8, strain_increment=SERVO_INC, output_interval=SERVO_OUTPUT_INTERVAL,
                                  tests=("ttc",), end_strain=SERVO_STRAIN,
                                  servo={"gain": gain, "integral_gain": igain}, role="stability", knob="servo",
                                  value=[gain, igain]))
    return plan


def preparation_specs(tc):
    """Samples prepared at a larger time step or servo cap, then the paper's tests."""
    plan = []
    # Samples prepared at a larger time step (a preset's dt changes its preparation too), then the paper's tests.
    for dt, seeds in ((3e-6, (1, 2)), (5e-6, (1,))):
        for seed in seeds:
            plan.append(sample_spec(seed=seed, time_step=dt, priority=9))
            plan.append(test_spec(f"prepdt_{dt:g}_s{seed}", "prepare_dt", f"sample prepared at dt = {dt / tc:.2f} t_c",
                                  9 if seed == 1 else 11, seed=seed, sample_dt=dt, knob="prepare_dt", value=dt))
    # Samples prepared with a larger servo.max_strain_increment (the presets raise it to 5 × their Δε1, and the
    # preparation's servo uses it too), then the paper's tests.
    for cap in (2.5e-6, 5e-6):
        for seed in (1, 2):
            plan.append(sample_spec(seed=seed, servo_cap=cap, priority=9))
            plan.append(test_spec(f"prepcap_{cap:g}_s{seed}", "prepare_dt",
                                  f"sample prepared with servo.max_strain_increment {cap:g}", 9, seed=seed,
                                  sample_cap=cap, knob="prepare_cap", value=cap))
    return plan


def count_specs():
    """Particle count: each count its own sample, the paper's test settings."""
    plan = []
    # Particle count: each count its own sample, the paper's test settings.
    for count in (500, 2000):
        plan.append(sample_spec(count=count, seed=1, priority=10))
        plan.append(test_spec(f"count_{count}_s1", "count", f"{count} spheres", 10, count=count,
                              knob="count", value=count))
    return plan


def more_seed_specs(plan):
    """The settings of MORE_SEEDS in `plan` on seeds 3 and 4 as well."""
    more = []
    # The settings nearest the reference (the candidates for the presets) on seeds 3 and 4 as well: their errors are
    # a fraction of the noise floor, and two seeds leave too much chaotic scatter in the mean.
    for spec in [s for s in plan if s["kind"] == "test" and s["seed"] == 1
                 and s["name"].rsplit("_s", 1)[0] in MORE_SEEDS]:
        for seed in (3, 4):
            extra = copy.deepcopy(spec)
            extra.update(name=f"{spec['name'].rsplit('_s', 1)[0]}_s{seed}", seed=seed,
                         priority=max(5, spec["priority"]),
                         sample=sample_name(spec["count"], seed))
            more.append(extra)
    return more


def deck_of(spec, paper=None, state_path="prepared.state"):
    """The deck a spec runs (a test run's deck starts from `state_path`). A spec that carries its own "deck"
    (tools/sufficiency.py) runs that: a sample its preparation only, a test its tests from the sample."""
    if spec.get("deck") is not None:
        if spec["kind"] == "sample":
            return decks.edited(spec["deck"], {"tests": []})
        # A switch runs other physics from the baseline's sample on purpose (the state records the baseline's).
        return decks.edited(spec["deck"], {"prepare": None, "initial_state": state_path, "override_state_physics": True})
    paper = paper or decks.load()
    return sample_deck(paper, spec) if spec["kind"] == "sample" else run_deck(paper, spec, state_path)


def estimated_cost(spec, deck_plan):
    """Particle-steps of a run: its tests' steps from its plan; a preparation counts SAMPLE_STEPS_ESTIMATE."""
    if spec["kind"] == "sample":
        return spec["count"] * SAMPLE_STEPS_ESTIMATE
    return spec["count"] * sum(t["steps"] for t in deck_plan["tests"])


def costs(plan, paper, celldem):
    """{run name: estimated particle-steps}, one `celldem plan` per test run."""
    return {s["name"]: estimated_cost(s, None if s["kind"] == "sample" else
                                      binary.plan_deck(deck_of(s, paper), None, celldem)) for s in plan}


def select(plan, only=None, max_priority=None):
    """The runs of `plan` in the groups or names `only` (their samples come along) and of at most `max_priority`
    (and the samples those need)."""
    if only:
        wanted = set(only)
        plan = [s for s in plan if s["group"] in wanted or s["name"] in wanted or s["kind"] == "sample"]
    if max_priority is not None:
        tests = [s for s in plan if s["kind"] == "test" and s["priority"] <= max_priority]
        needed = {s["sample"] for s in tests}
        plan = [s for s in plan if s in tests or (s["kind"] == "sample" and
                                                  (s["name"] in needed or s["priority"] <= max_priority))]
    return plan


# ---- decks: the paper deck with values changed ----------------------------------------------------------------

def sample_deck(paper, spec):
    changes = {"description": f"celldem study: preparation of {spec['label']} (paper settings otherwise)",
               "sample.count": spec["count"], "sample.seed": spec["seed"], "time_step": spec["time_step"],
               "tests": []}
    if spec.get("servo_cap") is not None:
        changes["servo.max_strain_increment"] = spec["servo_cap"]
    return decks.edited(paper, changes)


def run_deck(paper, spec, state_path):
    changes = {"description": f"celldem study: {spec['label']} ({spec['count']} spheres, seed {spec['seed']})",
               "prepare": None, "initial_state": state_path, "override_state_physics": True,
               "sample.count": spec["count"], "sample.seed": spec["seed"],
               "sample.density": paper["sample"]["density"] * spec["density_factor"],
               "time_step": spec["time_step"],
               "damping.translational": spec["damping"][0], "damping.rotational": spec["damping"][1]}
    changes.update({f"contact.{k}": v for k, v in spec["contact"].items()})
    if spec["kinematics"]:
        changes["kinematics"] = spec["kinematics"]
    changes.update({f"servo.{k}": v for k, v in (spec["servo"] or {}).items()})
    deck = decks.edited(paper, changes)
    deck["tests"] = [decks.edited(t, {"axes.x1": {"strain_increment": spec["strain_increment"]},
                                      "end.strain": spec["end_strain"], "output_interval": spec["output_interval"]})
                     for t in paper["tests"] if t["name"] in spec["tests"]]
    return deck


PAPER_PREPARED_STATE = "../results/paper/prepared.state"   # relative to inputs/: what tools/paper.sh prepares


def preset_deck(paper, name, time_step, strain_increment, output_interval, description, preparation="own"):
    """A paper deck (8000 spheres, ε1 to 10 %) with only the time step, strain increment, the servo's cap on the
    strain per step (5 × the strain increment, the paper's ratio) and the output interval changed.

    preparation "own": the deck keeps "prepare" (which then runs with the preset's time step and servo cap);
    "paper": the deck starts from the paper deck's prepared sample instead ("initial_state"), as the study's runs
    did, for presets whose own preparation was not shown to give the same sample."""
    deck = decks.edited(paper, {"description": description, "time_step": time_step})
    if preparation == "paper":  # "initial_state" where "prepare" was
        deck = {("initial_state" if k == "prepare" else k): (PAPER_PREPARED_STATE if k == "prepare" else v)
                for k, v in deck.items()}
    if strain_increment != PAPER_INC:  # after time_step, as the README lists the keys
        servo = dict(deck.get("servo", {}), max_strain_increment=SERVO_CAP_FACTOR * strain_increment)
        deck = decks.insert_after(deck, "time_step", "servo", servo)
    deck["tests"] = [decks.edited(t, {"axes.x1": {"strain_increment": strain_increment},
                                      "output_interval": output_interval}) for t in deck["tests"]]
    return deck


# ---- running ------------------------------------------------------------------------------------------------

def run_dir(root, spec):
    return os.path.join(root, "samples" if spec["kind"] == "sample" else "runs", spec["name"])


def write_json(path, data):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=1)
    os.replace(tmp, path)


def outcome(root, spec):
    return read_json(os.path.join(run_dir(root, spec), "outcome.json"))


def is_done(root, spec, retry_failed=False):
    out = outcome(root, spec)
    return out is not None and (out.get("rc") == 0 or not retry_failed)


def sample_ready(root, spec):
    out = outcome(root, spec)
    return out is not None and out.get("rc") == 0 and os.path.isfile(
        os.path.join(run_dir(root, spec), "prepared.state"))


def remove_quietly(path):
    try:
        os.remove(path)
    except OSError:
        pass


def save_plan(directory, celldem):
    """DIR/plan.json = `celldem plan DIR/deck.json --json`: what the analysis reads instead of deriving it."""
    write_json(os.path.join(directory, "plan.json"), binary.plan(os.path.join(directory, "deck.json"), celldem))


def fill_missing_plans(root, celldem):
    """plan.json for run folders of an older study.py that has none (needs the binary); returns how many."""
    made = 0
    for kind in ("samples", "runs"):
        base = os.path.join(root, kind)
        for name in sorted(os.listdir(base)) if os.path.isdir(base) else []:
            d = os.path.join(base, name)
            if os.path.isfile(os.path.join(d, "deck.json")) and not os.path.isfile(os.path.join(d, "plan.json")):
                save_plan(d, celldem)
                made += 1
    return made


class Job:
    def __init__(self, spec, proc, log, directory, started):
        self.spec, self.proc, self.log, self.directory, self.started = spec, proc, log, directory, started


def start(root, paper, spec, celldem, samples):
    directory = run_dir(root, spec)
    os.makedirs(directory, exist_ok=True)
    state = None if spec["kind"] == "sample" else os.path.relpath(
        os.path.join(run_dir(root, samples[spec["sample"]]), "prepared.state"), directory)
    write_json(os.path.join(directory, "deck.json"), deck_of(spec, paper, state))
    write_json(os.path.join(directory, "spec.json"), spec)
    save_plan(directory, celldem)
    resume = read_json(os.path.join(directory, "progress.json")) is not None
    if not resume:
        remove_quietly(os.path.join(directory, "partial_cpu.json"))
    cmd = binary.run_command("deck.json", ".", threads=1, quiet=True, resume=resume, force=not resume,
                             binary=celldem)
    proc, log = binary.start_run(cmd, directory, append_log=True)
    return Job(spec, proc, log, directory, time.monotonic())


def finish(job, rc, rusage):
    job.log.close()
    cpu = rusage.ru_utime + rusage.ru_stime if rusage else None
    partial_path = os.path.join(job.directory, "partial_cpu.json")
    partial = (read_json(partial_path) or {}).get("cpu_s", 0.0)
    if rc == 130:  # stopped by a signal: celldem left a checkpoint, the next `run` resumes it
        write_json(partial_path, {"cpu_s": partial + (cpu or 0.0)})
        return None
    if rc != 0 and "--resume" in job.proc.args:
        # A failed resume (a checkpoint of another celldem build, say): start afresh at the next `run`.
        for name in ("progress.json", "partial_cpu.json"):
            remove_quietly(os.path.join(job.directory, name))
        return None
    tail = ""
    try:
        with open(os.path.join(job.directory, "celldem.log"), encoding="utf-8", errors="replace") as f:
            tail = f.read()[-2000:]
    except OSError:
        pass
    data = {"rc": rc, "wall_s": time.monotonic() - job.started,
            "cpu_s": None if cpu is None else cpu + partial,
            "host": socket.gethostname(), "finished": time.strftime("%Y-%m-%d %H:%M:%S"), "log_tail": tail}
    # Final states are not needed by the study (only the prepared ones are).
    for test in job.spec.get("tests", []):
        remove_quietly(os.path.join(job.directory, test, "final.state"))
    write_json(os.path.join(job.directory, "outcome.json"), data)
    return data


def record_binary(root, celldem):
    """Appends the celldem binary this `run` uses (path, sha256, build time, git HEAD) to ROOT/binaries.json."""
    with open(celldem, "rb") as f:
        digest = hashlib.sha256(f.read()).hexdigest()
    head = subprocess.run(["git", "-C", binary.REPO, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    path = os.path.join(root, "binaries.json")
    seen = read_json(path) or []
    if not any(b.get("sha256") == digest for b in seen):
        seen.append({"path": os.path.abspath(celldem), "sha256": digest,
                     "built": time.strftime("%Y-%m-%d %H:%M:%S", time.localtime(os.path.getmtime(celldem))),
                     "git_head_at_first_use": head.stdout.strip() or None})
        write_json(path, seen)


def next_ready(root, todo, samples, busy, skipped):
    """The first run of `todo` that can start now (its sample prepared), or None; runs whose sample failed or is
    not in the plan go into `skipped`."""
    for s in todo:
        if s["name"] in busy or s["name"] in skipped:
            continue
        if s["kind"] == "test":
            dep = samples.get(s["sample"])
            if dep is None:
                skipped.add(s["name"])
                continue
            dep_out = outcome(root, dep)
            if dep_out is not None and dep_out.get("rc") != 0:
                print(f"  skip {s['name']}: its sample {dep['name']} failed", flush=True)
                skipped.add(s["name"])
                continue
            if not sample_ready(root, dep):
                continue
        return s
    return None


def run_all(root, paper, plan, todo, celldem, jobs=1, stop_after=None, hard_stop=None):
    """Runs `todo` (runs of `plan`), `jobs` at a time, samples before the runs that need them. SIGINT/SIGTERM stop
    the running runs (they resume next time); so does `hard_stop` seconds; no run starts after `stop_after`."""
    samples = {s["name"]: s for s in plan if s["kind"] == "sample"}
    t0 = time.monotonic()
    running = []
    stopping = {"now": False}

    def on_signal(signum, _frame):
        stopping["now"] = True
        for job in running:
            job.proc.send_signal(signal.SIGTERM)

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    skipped = set()
    while True:
        elapsed = time.monotonic() - t0
        may_start = not stopping["now"] and (stop_after is None or elapsed < stop_after)
        while may_start and len(running) < jobs:
            ready = next_ready(root, todo, samples, {j.spec["name"] for j in running}, skipped)
            if ready is None:
                break
            todo.remove(ready)
            running.append(start(root, paper, ready, celldem, samples))
            print(f"  start {ready['name']} ({ready['label']})", flush=True)
        if not running:
            break
        pid, status, rusage = os.wait4(-1, 0)
        job = next((j for j in running if j.proc.pid == pid), None)
        if job is None:
            continue
        running.remove(job)
        job.proc.returncode = os.waitstatus_to_exitcode(status)
        data = finish(job, job.proc.returncode, rusage)
        state = "stopped (resumes next time)" if data is None else (
            f"done in {data['wall_s']:.1f} s wall, {data['cpu_s']:.1f} s CPU" if data["rc"] == 0
            else f"FAILED rc {data['rc']}: {(data['log_tail'].strip().splitlines() or [''])[-1]}")
        print(f"  {job.spec['name']}: {state}", flush=True)
        if hard_stop is not None and time.monotonic() - t0 > hard_stop and not stopping["now"]:
            on_signal(signal.SIGTERM, None)


# ---- presets ----------------------------------------------------------------------------------------------------

def write_presets(study, paper, celldem):
    """inputs/<name>.json for each preset the analysis chose; `celldem check`ed when the binary is there."""
    written = []
    for name, p in study["presets"].items():
        desc = (f"Preset '{name}' from tools/study.py: the paper deck with time_step {p['time_step']:g} s "
                f"({p['dt_over_tc']:.2f} t_c) and axial strain increment {p['strain_increment']:g}/step (I = "
                f"{p['inertial_number']:.1e}); on the reduced study scene: {p['rule']}; "
                f"tests {p['test_steps_speedup']:.1f}x fewer steps than inputs/paper.json (tools/study.py)")
        if p["preparation"] == "paper":
            desc += (f"; starts from the paper deck's prepared sample ({PAPER_PREPARED_STATE}: run inputs/paper.json "
                     "or tools/paper.sh first) because the preset's time step or servo cap would change the "
                     "preparation")
        deck = preset_deck(paper, name, p["time_step"], p["strain_increment"], p["output_interval"], desc,
                           p["preparation"])
        path = os.path.join(binary.REPO, "inputs", f"{name}.json")
        decks.write(path, deck)
        written.append(path)
        if os.access(celldem, os.X_OK):
            try:
                binary.check(path, celldem)
            except binary.BinaryError as err:
                print(f"study.py: warning: celldem check {path} failed: {err}", file=sys.stderr)
    return written


RULES_PATH = os.path.join(binary.REPO, "solver", "io", "time_to_answer_rules.json")


def write_rules(study, path=RULES_PATH):
    """The time-to-answer rules from the study (analysis.rules_levels), as celldem reads them at build time; the
    binary carries them once rebuilt. Refuses a study that gives fewer than two levels."""
    levels = rules_levels(study)
    if len(levels) < 2:
        raise ValueError(f"the study gives {len(levels)} level(s) of the time-to-answer rules; at least 2 are needed")
    table = {
        "format": 1,
        "description": ("What `--tolerance T` (T in noise floors) does to a deck's cost knobs, per level; celldem "
                        "interpolates log-linearly in T between levels and refuses T outside them. Written by "
                        "tools/study.py analyse --write-rules from the study's results: at each level the cheapest "
                        "setting whose error (the mean over seeds of the paired difference from the paper's settings, "
                        "over the seed-to-seed standard deviation) is at most T."),
        "particles": study["scene"]["count"],
        "source": f"tools/study.py on {study['scene']['count']} spheres, tests to e1 = {study['scene']['end_strain']:g}, "
                  f"reference seeds {study['scene']['reference_seeds']}",
        "columns": {
            "tolerance": "T, noise floors",
            "time_step_fraction": "tests' time step / the stage's stability limit (core/plan critical_time_step)",
            "prepare_time_step_fraction": "the preparation's time step / the stability limit",
            "inertial_number": "strain-driven legs: strain rate = I / (d_mean sqrt(rho / p)), p the leg's confining stress",
            "fast_strain_increment_scale": "the preparation's fast-compression strain rate (its strain per step over the stage's time step), times the deck's; its servo leg's cap keeps the deck's strain rate too",
            "damping_scale": "body damping (translational and rotational), times the deck's",
        },
        "levels": levels,
    }
    # The rate bias laws (the strain-driven legs' rate, from the rate ladder: docs/study.md) are not the study's to
    # write: kept from the table being replaced.
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            old = json.load(f)
        if "rate_bias" in old:
            table["rate_bias"] = old["rate_bias"]
    tmp = path + ".tmp"  # whole or not at all: the build embeds it
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(json.dumps(table, indent=2) + "\n")
    os.replace(tmp, path)
    return path
