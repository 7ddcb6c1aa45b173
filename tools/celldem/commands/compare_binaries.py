"""Two celldem binaries timed against each other: `celldem bench` (one thread, the shear phase of a deck's test) of
both at once, each pinned to a core of its own, then with the cores swapped, in each round; the verdict on new
over old with its test and interval (method: tools/celldem/performance/paired.py). With --whole-process, whole
`celldem run DECK` processes (one thread, start-up and every write included) instead, timed by the wall clock.
With --equivalence, their results instead of their speed: paired seeds (each binary prepares each seed's sample and
runs the tests from it) judged by TOST on every summary quantity within ±0.5 noise floor of a reference ensemble
(OLD on seeds not judged), or a holding control's tolerance, with a check of the spreads, or "identical bits"
(method: tools/celldem/performance/equivalence.py).

Usage: /usr/bin/python3 tools/compare_binaries.py OLD NEW [--rounds 8] [--steps 4000] [--warmup 1000]
                                                  [--deck inputs/paper.json] [--state results/paper/prepared.state]
                                                  [--whole-process] [--bar 1.05] [--json FILE]
       /usr/bin/python3 tools/compare_binaries.py OLD NEW --equivalence [--seeds 30 | --seeds 1-30] [--margin 0.5]
                                                  [--reference-seeds 1001-1020 | --reference DIR]
                                                  [--deck DECK] [--out DIR] [--jobs 2] [--force] [--json FILE]

Timing needs two cores and nothing else running: each round takes both. Exit 0 with the verdict printed (and
written to --json), 2 on bad input or a failed bench. --equivalence: exit 0 when equivalent or identical, 1 when
not shown equivalent, 2 on bad input or a failed run, 130 when stopped (the same command continues).
"""

import argparse
import os
import sys

from celldem import binary
from celldem.files import read_json
from celldem.study.runs import write_json
from celldem.performance import equivalence, paired

TIMING_DEFAULTS = {"rounds": 8, "steps": 4000, "warmup": 1000,
                   "state": os.path.join(binary.REPO, "results", "paper", "prepared.state"),
                   "whole_process": False, "bar": paired.BAR}
EQUIVALENCE_DEFAULTS = {"seeds": str(equivalence.DEFAULT_SEEDS), "margin": equivalence.MARGIN_FLOORS, "out": None,
                        "jobs": equivalence.DEFAULT_JOBS, "force": False, "reference_seeds": None,
                        "reference": None}


def fail(message):
    print(f"compare_binaries.py: error: {message}", file=sys.stderr)
    return 2


def main(argv=None):
    parser = argparse.ArgumentParser(description="Two celldem binaries compared: their speed in concurrent pinned "
                                                 "pairs, or with --equivalence their results on paired seeds.")
    parser.add_argument("old", help="the binary to compare against")
    parser.add_argument("new", help="the binary being judged")
    parser.add_argument("--rounds", type=int, default=None, help="rounds of two halves (default 8; at least 2)")
    parser.add_argument("--steps", type=int, default=None, help="timed steps of each bench (default 4000)")
    parser.add_argument("--warmup", type=int, default=None, help="untimed steps before them (default 1000)")
    parser.add_argument("--deck", default=None,
                        help="deck of the scene (timing: default inputs/paper.json; --equivalence: default the "
                             "study's 1000-sphere reference scene)")
    parser.add_argument("--state", default=None, help="prepared sample to start from (timing; default "
                                                      "results/paper/prepared.state)")
    parser.add_argument("--whole-process", action="store_true", default=None,
                        help="time whole `celldem run DECK` processes (1 / wall seconds) instead of the bench")
    parser.add_argument("--bar", type=float, default=None,
                        help=f"the gain the interval's lower end must clear (default {paired.BAR})")
    parser.add_argument("--equivalence", action="store_true",
                        help="compare the binaries' results on paired seeds instead of their speed")
    parser.add_argument("--seeds", default=None,
                        help=f"--equivalence: N (seeds 1-N) or A-B, at least {equivalence.MIN_SEEDS} "
                             f"(default {equivalence.DEFAULT_SEEDS})")
    parser.add_argument("--margin", type=float, default=None,
                        help="--equivalence: the margin in noise floors of the reference ensemble (default "
                             f"{equivalence.MARGIN_FLOORS}); a quantity a control holds: at least its tolerance")
    parser.add_argument("--reference-seeds", default=None,
                        help="--equivalence: the seeds OLD alone runs for the floors, N or A-B, none of them judged "
                             f"(default {equivalence.DEFAULT_REFERENCE_SEEDS}; run only when the bits differ)")
    parser.add_argument("--reference", default=None,
                        help="--equivalence: a `celldem run DECK --seeds` folder of the same deck (OLD's) to take the "
                             "floors from instead of --reference-seeds")
    parser.add_argument("--out", default=None, help="--equivalence: the study's folder (default "
                                                    "results/equivalence/<old>-vs-<new>[-<deck>])")
    parser.add_argument("--jobs", type=int, default=None,
                        help="--equivalence: celldem runs at once, one thread each "
                             f"(default {equivalence.DEFAULT_JOBS})")
    parser.add_argument("--force", action="store_true", default=None,
                        help="--equivalence: remove the results already in --out and start again")
    parser.add_argument("--json", default=None, help="also write the verdict (and every round) here")
    args = parser.parse_args(argv)

    mine, others = ((EQUIVALENCE_DEFAULTS, TIMING_DEFAULTS) if args.equivalence
                    else (TIMING_DEFAULTS, EQUIVALENCE_DEFAULTS))
    given = [name for name in others if getattr(args, name) is not None]
    if given:
        flags = ", ".join("--" + name.replace("_", "-") for name in given)
        return fail(f"{flags} {'do' if len(given) > 1 else 'does'} not apply "
                    f"{'with' if args.equivalence else 'without'} --equivalence")
    for name, value in mine.items():
        if getattr(args, name) is None:
            setattr(args, name, value)
    if args.json and os.path.exists(args.json):
        return fail(f"--json: {args.json} exists (remove it first)")
    if args.json:
        folder = os.path.dirname(os.path.abspath(args.json))
        if not (os.path.isdir(folder) and os.access(folder, os.W_OK)):
            return fail(f"--json: cannot write {args.json} (no writable folder {folder})")
    if not args.equivalence:
        return timing_main(args)
    try:
        return equivalence_main(args)
    except OSError as e:  # a folder or file the study cannot write (a full disk, permissions)
        return fail(f"{e.filename or 'a file'}: {e.strerror or e}")


def timing_main(args):
    args.deck = args.deck or os.path.join(binary.REPO, "inputs", "paper.json")
    for what, path in (("old", args.old), ("new", args.new)):
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            return fail(f"no executable {what} binary at {path}")
    needed = (("deck", args.deck),) if args.whole_process else (("deck", args.deck), ("state", args.state))
    for what, path in needed:
        if not os.path.isfile(path):
            return fail(f"no {what} at {path}")
    if args.rounds < 2:
        return fail(f"--rounds must be at least 2 (a verdict needs a spread), got {args.rounds}")
    if args.steps < 1 or args.warmup < 0:
        return fail("--steps must be at least 1 and --warmup at least 0")
    if not args.bar > 0:
        return fail(f"--bar must be positive, got {args.bar}")
    rounds = []
    try:
        for k in range(args.rounds):
            r = paired.run_round(os.path.abspath(args.old), os.path.abspath(args.new), args.deck,
                                 None if args.whole_process else args.state, args.steps, args.warmup)
            rounds.append(r)
            unit = "processes/s" if args.whole_process else "particle-steps/s"
            print(f"round {k + 1}/{args.rounds}: old {r['old']:.4g}, new {r['new']:.4g} {unit}, new/old "
                  f"{r['ratio']:.3f} (halves {r['first_half']:.3f}, {r['second_half']:.3f})", flush=True)
    except paired.PairedError as e:
        return fail(str(e))
    verdict = paired.judge([r["ratio"] for r in rounds], args.bar)
    print(verdict.text())
    if args.json:
        write_json(args.json, {**verdict.as_dict(), "rounds_detail": rounds, "old": os.path.abspath(args.old),
                               "new": os.path.abspath(args.new), "whole_process": args.whole_process,
                               "steps": args.steps, "warmup": args.warmup, "deck": args.deck, "state": args.state})
    return 0


def equivalence_main(args):
    try:
        old = equivalence.check_binary("old", args.old)
        new = equivalence.check_binary("new", args.new)
        seeds = equivalence.parse_seeds(args.seeds)
        margin = equivalence.check_margin(args.margin)
        if args.reference is not None and args.reference_seeds is not None:
            raise equivalence.EquivalenceError("--reference and --reference-seeds exclude each other: the floors come "
                                               "from a stored ensemble or from seeds run here")
        stored = (equivalence.stored_reference(os.path.abspath(args.reference), seeds)
                  if args.reference is not None else None)
        reference_seeds = ([] if stored is not None else equivalence.parse_reference_seeds(
            args.reference_seeds or equivalence.DEFAULT_REFERENCE_SEEDS, seeds))
        cpus = len(os.sched_getaffinity(0))
        if not 1 <= args.jobs <= cpus:
            raise equivalence.EquivalenceError(f"--jobs must be from 1 to the {cpus} CPUs this process may use (each "
                                               f"run takes one), got {args.jobs}")
        scene = equivalence.deck_scene(args.deck, old) if args.deck else equivalence.study_scene()
        out = os.path.abspath(args.out or equivalence.default_out(old, new, args.deck))
        lock = equivalence.open_folder(out, equivalence.identity(old, new, scene, margin), args.force)
    except equivalence.EquivalenceError as e:
        return fail(str(e))
    with lock:
        try:
            ran = equivalence.run_seeds(out, scene, old, new, seeds, args.jobs)
            missing = [s for s in seeds if not equivalence.seed_complete(out, s)]
            if missing:
                return fail(f"seeds {missing} are not complete in {out} (run the same command again)")
            reference = stored
            if stored is None and any(equivalence.seed_differences(out, s) for s in seeds):
                more = equivalence.run_seeds(out, scene, old, new, reference_seeds, args.jobs, reference=True)
                ran = {"ran": ran["ran"] + more["ran"], "wall_s": ran["wall_s"] + more["wall_s"]}
                reference = equivalence.side(out, "old", reference_seeds)
            result = equivalence.judge(out, seeds, margin, reference=reference)
            result["reference"] = (f"stored: {os.path.abspath(args.reference)}" if stored is not None
                                   else "run here by OLD")
        except equivalence.RunFailed as e:
            return fail(str(e))
        except equivalence.Stopped as e:
            print(f"compare_binaries.py: {e}", file=sys.stderr)
            return 130
        except equivalence.study_compare.CompareError as e:
            return fail(f"the two binaries' results cannot be compared: {e}")
        result.update(old=old, new=new, scene=scene.description, deck=scene.deck_path, out=out,
                      wall_s_this_call=ran["wall_s"], seeds_run_this_call=ran["ran"],
                      run_wall_s=run_walls(out, seeds))
        text = equivalence.markdown(result, old, new, scene)
        print(text, end="")
        with open(os.path.join(out, "equivalence.md"), "w", encoding="utf-8") as f:
            f.write(text)
        write_json(os.path.join(out, "verdict.json"), result)
        if args.json:
            write_json(args.json, result)
    return result["exit"]


def run_walls(out, seeds):
    """{role: [wall seconds of each judged seed's run]} from the runs' done.json (earlier calls' included)."""
    walls = {}
    for role in equivalence.ROLES:
        done = [read_json(os.path.join(equivalence.run_dir(out, role, s), equivalence.DONE))
                for s in seeds]
        walls[role] = [d.get("wall_s") for d in done if isinstance(d, dict)]
    return walls
