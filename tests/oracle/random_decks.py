#!/usr/bin/python3
"""Seeded random decks across the deck's key space, each run by `celldem run` and judged.

Each draw is a small deck (one test of one to three legs, a few thousand steps) on one prepared sample of 300
spheres (made once per invocation and reused through `initial_state`): normal axes on strain, stress, stress_ramp,
mean_stress, b and constant_volume; shear axes on strain or stress (zero_shear_stress too); simple_shear;
principal-axis rotation; the adaptive rate; repeat blocks; the ends strain, shear strain, ratio, stress, steps and
equilibrium; the linear, Hertz-Mindlin and rolling laws; servo caps and control_failure warn. Many are unreachable
or too fast on purpose (a shear stress of 1e12 Pa or beyond its Coulomb limit, a rotation at 1e9 deg/s, an adaptive
max_factor of 1000 with targets at 1, a tiny servo cap).

The rule each draw must keep: exit 0 means the oracle (oracle.py) agrees with summary.json; exit 1 or 2 prints a
message naming a deck key or a component (x1 .. x23, b, mean stress); any other exit, or a run past its time
limit, fails.

    /usr/bin/python3 tests/oracle/random_decks.py --draws 200 --seed 1 --binary build/celldem [--out DIR]

Draw i of seed S uses the random stream seeded with (S, i): `--seed S --first i --draws 1` runs it alone. Each
failing draw prints its seed, its index and the deck file it wrote (`celldem run DECK --out DIR` reproduces it).
"""

import argparse
import json
import os
import random
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import oracle  # noqa: E402

COUNT = 300
SAMPLE = {"count": COUNT, "diameters": {"min": 0.003, "max": 0.0045, "count": 4}, "density": 2650, "seed": 7,
          "grid_spacing": 0.005}
BASE = {"format": 1, "sample": SAMPLE, "contact": {"kn": 1e6, "kt": 1e6},
        "damping": {"translational": 0.05, "rotational": 0.05}, "time_step": 1e-6}
P0 = 1e5  # the prepared sample's pressure


def preparation_deck():
    d = dict(BASE)
    d["prepare"] = {"target_pressure": P0, "fast_strain_increment": 5e-5, "output_interval": 1000,
                    "equilibrium": {"min_steps": 2000, "max_steps": 300000, "unbalanced_force_ratio": 0.05,
                                    "check_interval": 500}}
    d["tests"] = []
    return d


def prepare_sample(binary, folder):
    """Prepares the shared sample into folder/sample (once); returns the path of its prepared.state."""
    state = os.path.join(folder, "sample", "prepared.state")
    if os.path.exists(state):
        return state
    os.makedirs(folder, exist_ok=True)
    deck = os.path.join(folder, "sample_deck.json")
    with open(deck, "w") as f:
        json.dump(preparation_deck(), f, indent=1)
    r = subprocess.run([binary, "run", deck, "--out", os.path.join(folder, "sample"), "--force"],
                       capture_output=True, text=True, env=dict(os.environ, OMP_NUM_THREADS="1"))
    if r.returncode != 0:
        raise RuntimeError(f"the sample's preparation failed ({r.returncode}):\n{r.stderr[-3000:]}")
    return state


# ----------------------------------------------------------------------------------------------------- drawing
def near(rng, x, spread=0.2):
    return round(x * (1 + rng.uniform(-spread, spread)), 3)


def draw_end(rng, leg_kind, driven, steps, strain_at, per_step):
    """An end for the leg. driven: the strain-driven normal axis (or None); strain_at: its strain at the leg start
    when known (None otherwise); per_step its strain per step."""
    r = rng.random()
    if driven and strain_at is not None and r < 0.45:
        return {"axis": driven, "strain": round(strain_at + per_step * steps, 9)}, strain_at + per_step * steps
    if driven and r < 0.55:
        return {"ratio": rng.choice([1.3, 1.8, 5.0]), "max_steps": steps}, None
    if driven and r < 0.6:
        axis = rng.choice(["x2", "x3"])
        return {"axis": axis, "strain": rng.choice([-0.002, 0.001]), "max_steps": steps}, None
    if r < 0.65:
        return {"axis": "x1", "stress": rng.choice([1.2e5, 2e5]), "max_steps": steps}, None
    end = {"steps": steps}
    if rng.random() < 0.1:
        end["max_steps"] = steps // 2
    nxt = None if strain_at is None or not driven else strain_at + per_step * (end.get("max_steps") or steps)
    return end, nxt


def stress_axis(rng):
    r = rng.random()
    if r < 0.8:
        return {"stress": near(rng, P0, 0.1)}
    if r < 0.9:
        return {"stress_ramp": {"from": P0, "rate": rng.choice([-3e6, 5e6, 3e7])}}
    return {"stress": rng.choice([1e12, 1e3])}  # unreachable, or far below the packing's


def draw_leg(rng, steps, strain_at, first):
    """One leg (a dict of the deck) and the strain of x1 after it when known."""
    kind = rng.choices(["triaxial", "simple_shear", "hold", "rotation", "ramp"], [5, 2, 1.5, 1.5, 1])[0]
    leg = {}
    driven, per_step = None, 0.0
    if kind == "triaxial":
        inc = rng.choice([1, 1, -1]) * rng.choices([1e-6, 2e-6, 5e-6, 3e-5], [3, 3, 2, 1])[0]
        x1 = {"strain_increment": inc} if rng.random() < 0.7 else {"strain_rate": inc / 1e-6}
        mode = rng.choices(["stress", "b", "mean_stress", "constant_volume", "psc", "ramp"], [4, 1, 1, 1, 1, 1])[0]
        if mode == "stress":
            axes = {"x1": x1, "x2": stress_axis(rng), "x3": stress_axis(rng)}
        elif mode == "b":
            axes = {"x1": x1, "x2": {"b": rng.choice([0.0, 0.3, 0.5, 1.0])},
                    "x3": rng.choice([{"stress": P0}, {"mean_stress": P0}])}
        elif mode == "mean_stress":
            axes = {"x1": x1, "x2": {"mean_stress": near(rng, P0, 0.05)}}
            axes["x3"] = dict(axes["x2"])
        elif mode == "constant_volume":
            axes = {"x1": x1, "x2": {"constant_volume": True}, "x3": {"constant_volume": True}}
        elif mode == "psc":
            axes = {"x1": x1, "x2": {"strain_increment": 0}, "x3": {"stress": near(rng, P0, 0.1)}}
        else:
            axes = {"x1": x1, "x2": {"stress": P0}, "x3": {"stress_ramp": {"from": P0, "rate": rng.choice([-5e6, 1e7])}}}
        r = rng.random()
        if r < 0.25:  # a shear stress axis: held, unreachable, or beyond the Coulomb limit
            axes["x12"] = {"stress": rng.choice([0.0, 2e4, -3e4, 1e12, -1e5])}
        elif r < 0.35:
            axes[rng.choice(["x13", "x23"])] = {"strain_increment": rng.choice([2e-6, -1e-5])}
        elif r < 0.45 and mode in ("b", "mean_stress"):
            leg["zero_shear_stress"] = True
        leg["axes"] = axes
        driven, per_step = "x1", inc
    elif kind == "simple_shear":
        g = rng.choice([1, -1]) * rng.choices([2e-6, 5e-6, 3e-5], [3, 2, 1])[0]
        leg["simple_shear"] = ({"gamma_increment": g} if rng.random() < 0.7 else {"gamma_rate": g / 1e-6})
        leg["simple_shear"]["normal_stress"] = near(rng, P0, 0.1)
        # g12 counts from the test start: a strain end only where the test starts with this leg
        leg["end"] = {"axis": "x12", "strain": round(g * steps, 9)} if first and rng.random() < 0.5 else {"steps": steps}
    elif kind == "hold":  # no strain-driven axis: stresses and shear stresses held
        leg["axes"] = {"x1": {"stress": near(rng, P0, 0.03)}, "x2": {"stress": P0}, "x3": stress_axis(rng)}
        r = rng.random()
        if r < 0.5:
            leg["axes"]["x12"] = {"stress": rng.choice([3e4, 1e12, -1e5, 0.0])}
        if rng.random() < 0.2:  # a consolidation: reachable stresses only
            leg["axes"]["x3"] = {"stress": P0}
            leg["end"] = {"equilibrium": True, "max_steps": steps}
        else:
            leg["end"] = {"steps": steps}
    elif kind == "rotation":
        rot = {"plane": rng.choice(["x1x2", "x1x3", "x2x3"]), "sigma1": near(rng, 1.2e5, 0.05), "sigma3": P0,
               "from": rng.choice([0, 30])}
        if rng.random() < 0.8:
            rot["rate"] = rng.choice([3e3, 3e4, 1e6, 1e9]) * rng.choice([1, -1])
        else:
            rot["angle_increment"] = rng.choice([0.01, 0.5])
        other = {"x1x2": "x3", "x1x3": "x2", "x2x3": "x1"}[rot["plane"]]
        leg["axes"] = {other: rng.choice([{"stress": P0}, {"strain_increment": 0}])}
        leg["rotate_principal_axes"] = rot
        leg["end"] = {"steps": steps}
    else:  # a ramp alone drives the leg
        leg["axes"] = {"x1": {"stress_ramp": {"from": P0, "rate": rng.choice([1e7, 5e7, -1e7])}}, "x2": {"stress": P0},
                       "x3": {"stress": P0}}
        rate = leg["axes"]["x1"]["stress_ramp"]["rate"]
        leg["end"] = ({"axis": "x1", "stress": P0 * (1.2 if rate > 0 else 0.85), "max_steps": steps}
                      if rng.random() < 0.6 else {"steps": steps})
    if "end" not in leg:
        leg["end"], strain_after = draw_end(rng, kind, driven, steps, strain_at, per_step)
    else:
        strain_after = strain_at if kind == "simple_shear" else None  # (simple shear holds e1)
    if driven and rng.random() < 0.3 and "steps" not in leg["end"]:  # the adaptive rate (not with a steps end)
        ar = {}
        if rng.random() < 0.35:  # issue 38: the factor free to climb to 1000
            ar = {"max_factor": 1000, "unbalanced_force_ratio": 1, "kinetic_to_elastic": 1}
        else:
            if rng.random() < 0.5:
                ar["max_factor"] = rng.choice([8, 100, 1000])
            if rng.random() < 0.4:
                ar["unbalanced_force_ratio"], ar["kinetic_to_elastic"] = 1, 1
        if rng.random() < 0.3:
            ar["check_interval"] = rng.choice([10, 200])
        if not any("stress_ramp" in a for a in leg["axes"].values()):
            leg["adaptive_rate"] = ar
            if "strain" not in leg["end"] or leg["end"].get("axis", "x1") != "x1":
                strain_after = None
    if kind == "simple_shear" and rng.random() < 0.2 and "axis" in leg["end"]:
        leg["adaptive_rate"] = {"max_factor": rng.choice([8, 1000]), "unbalanced_force_ratio": 1, "kinetic_to_elastic": 1}
    return leg, strain_after


def draw_deck(rng, state_path):
    deck = json.loads(json.dumps(BASE))
    deck["initial_state"] = state_path
    law = rng.choices(["linear", "hertz", "rolling"], [6, 1, 1])[0]
    if law == "hertz":
        deck["contact"] = {"normal": "hertz", "tangential": rng.choice(["mindlin", "mindlin_rescale"]),
                           "youngs_modulus": 4e7, "poisson_ratio": 0.3}
        deck["override_state_physics"] = True
    elif law == "rolling":
        deck["contact"] = {"kn": 1e6, "kt": 1e6, "rolling": "sds", "rolling_stiffness": 2e5, "rolling_friction": 0.1}
        deck["override_state_physics"] = True
    if rng.random() < 0.15:
        deck["servo"] = {"max_strain_increment": rng.choice([1e-9, 1e-4])}
    if rng.random() < 0.2:
        deck["control_failure"] = "warn"
    test = {"name": "t", "friction": rng.choice([0.0, 0.3, 0.5]), "output_interval": rng.choice([50, 100, 250])}
    n_legs = rng.choices([1, 2, 3], [4, 3, 1])[0]
    legs, strain_at = [], 0.0
    for k in range(n_legs):
        steps = rng.choice([1000, 1500, 2500, 3000]) // (1 if n_legs == 1 else 2)
        leg, strain_at = draw_leg(rng, steps, strain_at, k == 0)
        legs.append(leg)
    if n_legs == 2 and rng.random() < 0.2 and all("steps" in leg["end"] for leg in legs):
        test["legs"] = [{"repeat": 2, "legs": legs}]
    elif n_legs == 1 and rng.random() < 0.6:
        test.update(legs[0])
    else:
        test["legs"] = legs
    if any(leg["end"].get("equilibrium") for leg in legs):
        test["equilibrium"] = {"min_steps": 200, "check_interval": 100, "unbalanced_force_ratio": 0.2}
    deck["tests"] = [test]
    return deck


# ------------------------------------------------------------------------------------------------------ judging
COMPONENT_WORDS = re.compile(r"\b(x1|x2|x3|x12|x13|x23|b|mean[ _]stress)\b")


def schema_keys(binary):
    """The deck's key names from `celldem schema --json`: each key's path and its trailing parts (tests[].end.max_steps
    gives end.max_steps and max_steps)."""
    r = subprocess.run([binary, "schema", "--json"], capture_output=True, text=True, check=True)
    out = set()
    for entry in json.loads(r.stdout):
        parts = entry["key"].replace("[]", "").split(".")
        for i in range(len(parts)):
            out.add(".".join(parts[i:]))
    return out


def names_key_or_component(message, keys):
    """Whether an error message names a component (x1 .. x23, b, mean stress) or a deck key: a dotted key path
    (servo.max_strain_increment), a key with an underscore (max_factor), or a key in quotes ("dynamic")."""
    if COMPONENT_WORDS.search(message):
        return True
    return any(k in message for k in keys if "." in k or "_" in k) or any(f'"{k}"' in message for k in keys)


def run_draw(binary, seed, index, state_path, folder, keys, timeout=300):
    """Draws, runs and judges one deck. Returns (verdict, detail, deck path): verdict 'agrees', 'refused' (exit 1 or
    2 naming a key or component) or 'FAILED'."""
    rng = random.Random(f"{seed}-{index}")
    deck = draw_deck(rng, state_path)
    deck_path = os.path.join(folder, f"deck-{seed}-{index}.json")
    out = os.path.join(folder, f"run-{seed}-{index}")
    with open(deck_path, "w") as f:
        json.dump(deck, f, indent=1)
    try:
        r = subprocess.run([binary, "run", deck_path, "--out", out, "--force"], capture_output=True, text=True,
                           timeout=timeout, env=dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="PASSIVE"))
    except subprocess.TimeoutExpired:
        return "FAILED", f"ran past {timeout} s", deck_path
    err = r.stderr.strip()
    if r.returncode == 0:
        problems = oracle.check_run(out, deck_path)
        if problems:
            return "FAILED", "exit 0 but the oracle disagrees:\n  " + "\n  ".join(problems), deck_path
        return "agrees", "", deck_path
    if r.returncode in (1, 2):
        message = "\n".join(line for line in err.splitlines() if "error" in line) or err
        if names_key_or_component(message, keys):
            return "refused", f"exit {r.returncode}: {message[-600:]}", deck_path
        return "FAILED", f"exit {r.returncode} without naming a key or component: {message[-600:]}", deck_path
    return "FAILED", f"exit {r.returncode}: {err[-600:]}", deck_path


def main(argv=None):
    p = argparse.ArgumentParser(description="Seeded random decks judged by the result oracle.")
    p.add_argument("--draws", type=int, default=20)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--first", type=int, default=0, help="index of the first draw (to rerun one: --first i --draws 1)")
    p.add_argument("--binary", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "build", "celldem"))
    p.add_argument("--out", help="folder for the sample, decks and runs (default: a new temporary folder)")
    p.add_argument("--verbose", action="store_true", help="print every draw's verdict and message")
    a = p.parse_args(argv)
    folder = os.path.abspath(a.out or tempfile.mkdtemp(prefix="celldem-oracle-"))
    binary = os.path.abspath(a.binary)
    state = prepare_sample(binary, folder)
    keys = schema_keys(binary)
    counts = {"agrees": 0, "refused": 0, "FAILED": 0}
    for i in range(a.first, a.first + a.draws):
        verdict, detail, deck_path = run_draw(binary, a.seed, i, state, folder, keys)
        counts[verdict] += 1
        if verdict == "FAILED" or a.verbose:
            print(f"draw seed {a.seed} index {i} [{verdict}] deck {deck_path}" + (f"\n  {detail}" if detail else ""),
                  flush=True)
    print(f"{a.draws} draws (seed {a.seed}, from {a.first}): {counts['agrees']} exit 0 and the oracle agrees, "
          f"{counts['refused']} exit 1/2 naming a key or component, {counts['FAILED']} failed; files in {folder}")
    return 1 if counts["FAILED"] else 0


if __name__ == "__main__":
    sys.exit(main())
