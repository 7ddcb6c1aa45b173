"""Speed–accuracy and stability study of celldem on a reduced scene of the paper's TTC and PSC.

Usage: /usr/bin/python3 tools/study.py plan                 list the runs and whether each is done
       /usr/bin/python3 tools/study.py run [--jobs N] ...   run what is missing (resumable, one run at a time
                                                            by default, most important runs first)
       /usr/bin/python3 tools/study.py analyse [--write-presets] [--write-rules [PATH]]
                                                            tables, charts, results/study/study.md and study.json;
                                                            with --write-presets also inputs/fast.json and
                                                            inputs/balanced.json; with --write-rules the
                                                            time-to-answer rules of `celldem --tolerance`
       /usr/bin/python3 tools/study.py plan|run|analyse --deck DECK --budget-core-hours H [--count N]
                                                            the study on any deck: its loading rate × 1 to 32,
                                                            as many settings and seeds as the budget allows,
                                                            the floor from its own ensemble, the chart
                                                            (results/study-<deck>/; celldem/study/any_deck.py)
       /usr/bin/python3 tools/study.py compare BASE_DIR OTHER_DIR [--margin FLOORS] [--json FILE]
                                                            two `celldem run --seeds` folders of one deck on the
                                                            same seeds: each summary quantity's mean paired
                                                            difference in BASE's floors, paired t and TOST, and
                                                            the particle-steps and wall-time ratios
       /usr/bin/python3 tools/study.py floors [--counts 500,1000,2000] [--seeds 1-8]
                                                            the noise floor against the particle count: the
                                                            evidence for --tolerance's floor model
                                                            (results/study-floors/floors.md; study/floors.py)

The scene: SCENE_COUNT spheres with the paper's sizes, density, contact law and preparation, tests to
ε1 = END_STRAIN (its report says where the reference seeds' peaks lie). Each sample is prepared once (samples/<name>/prepared.state)
and every setting is run from it with a deck that uses "initial_state" (runs/<name>/deck.json: inputs/paper.json
with values changed; plan.json beside it is `celldem plan deck.json --json`). A run is skipped when its
outcome.json exists; an interrupted one is resumed.

The accuracy of a setting: for each compared quantity (summary.json's peak σ1/σ3, ε1 and b at the peak, εv and
Z over the end window), the mean over its seeds of its difference from the reference (the paper's settings) on
the same sample, divided by the noise floor, the standard deviation of that quantity over reference samples that
differ only in sample.seed. Below 1 it is not an error. Runs with dt changed in its 9th digit show what
round-off alone (DEM is chaotic) does. The work is in tools/celldem/study/ (scene, runs, analysis,
report); tests/tools/test_study_analysis.py tests the analysis on synthetic results.

Decks for settings with a larger strain increment raise servo.max_strain_increment to 5 × Δε1 (the paper's own
ratio, 1e-6 = 5 × 2e-7): PSC's free axis dilates at about 2 × Δε1 per step and the default cap stops the servo
from following (the servo_cap runs, kept from a first pass, show it).
"""

import argparse
import os
import sys

from celldem import binary, decks
from celldem.study import analysis as study_analysis, any_deck, compare as study_compare, report as study_report
from celldem.study import floors as study_floors, runs as study_runs
from celldem.study.runs import DEFAULT_ROOT
from celldem.study.scene import END_STRAIN, SCENE_COUNT


def error(message):
    print(f"study.py: error: {message}", file=sys.stderr)
    return 2


def normal_time_step(plan):
    """The study's unit of time step, sqrt(m_min/kn) (`celldem plan`'s normal mode; older plans: the critical
    time step, which was that)."""
    return plan.get("normal_time_step", plan["critical_time_step"])


def cmd_plan(args):
    paper_info = args.paper_plan
    ttc = binary.test_plan(paper_info, "ttc")
    tc = normal_time_step(paper_info)
    print(f"scene: {SCENE_COUNT} spheres, tests to e1 = {END_STRAIN:g}; t_c = sqrt(m_min/kn) = "
          f"{tc:.3e} s; paper dt = {paper_info['time_step'] / tc:.3f} t_c; paper I = "
          f"{ttc['inertial_number']:.2e}")
    plan = study_runs.build_plan(tc)
    cost = study_runs.costs(plan, decks.load(), args.celldem)
    total = 0
    for s in plan:
        out = study_runs.outcome(args.root, s)
        state = "todo" if out is None else ("done" if out.get("rc") == 0 else f"failed rc {out.get('rc')}")
        total += cost[s["name"]] if out is None else 0
        print(f"  p{s['priority']:<2} {s['name']:<34} {state:<12} {cost[s['name']] / 1e6:8.1f}M  {s['label']}")
    print(f"left: about {total / 1e9:.2f}e9 particle-steps")
    return 0


def cmd_run(args):
    paper = decks.load()
    plan = study_runs.select(study_runs.build_plan(normal_time_step(args.paper_plan)), args.only,
                             args.max_priority)
    todo = [s for s in plan if not study_runs.is_done(args.root, s, args.retry_failed)]
    cost = study_runs.costs(todo, paper, args.celldem)
    if args.order == "cost":
        todo.sort(key=lambda s: (s["kind"] != "sample", -cost[s["name"]]))
    print(f"study: {len(todo)} runs to do of {len(plan)}, about {sum(cost.values()) / 1e9:.2f}e9 particle-steps; "
          f"results in {args.root}", flush=True)
    os.makedirs(args.root, exist_ok=True)
    study_runs.record_binary(args.root, args.celldem)
    study_runs.run_all(args.root, paper, plan, todo, args.celldem, args.jobs, args.stop_after, args.hard_stop)
    left = [s["name"] for s in plan if not study_runs.is_done(args.root, s, args.retry_failed)]
    print(f"study: {len(plan) - len(left)} of {len(plan)} runs done" + (f"; left: {', '.join(left)}" if left else ""))
    return 0


def cmd_analyse(args):
    if not os.path.isdir(args.root):
        return error(f"no study results in {args.root}")
    if os.access(args.celldem, os.X_OK):  # runs of an older study.py have no plan.json
        study_runs.fill_missing_plans(args.root, args.celldem)
    study = study_analysis.analyse(args.root)
    fig_dir = os.path.join(args.root, "figures")
    paths = study_report.draw_charts(study, fig_dir)
    ref_fig = study_report.draw_reference_curves(study_analysis.load_results(args.root), fig_dir)
    study_runs.write_json(os.path.join(args.root, "study.json"), study_report.jsonable(study))
    md = study_report.write_markdown(study, args.root, paths, ref_fig)
    print(f"wrote {md}, {os.path.join(args.root, 'study.json')}, {', '.join(paths.values())}")
    if args.write_presets:
        for p in study_runs.write_presets(study, decks.load(), args.celldem):
            print(f"wrote {p}")
    if args.write_rules:
        try:
            print(f"wrote {study_runs.write_rules(study, args.write_rules)} (rebuild celldem to carry it)")
        except ValueError as err:
            return error(err)
    return 0


def cmd_any_deck(args):
    """plan, run or analyse the study of args.deck (any_deck)."""
    root = os.path.abspath(args.root_given or any_deck.default_root(args.deck))
    try:
        if args.command == "plan" or (args.command == "run" and args.budget_core_hours is not None):
            if args.budget_core_hours is None:
                return error("plan --deck needs --budget-core-hours")
            plan = any_deck.plan_study(args.deck, root, args.budget_core_hours, args.celldem, args.count,
                                       args.throughput)
            print(f"study of {args.deck}: {plan['count']} spheres, {plan['seeds']} seeds, loading rate x "
                  f"{', '.join(f'{f:g}' for f in plan['factors'])}: about {plan['core_hours']:.3g} core-hours at "
                  f"{plan['throughput']:.3g} particle-steps/s ({plan['throughput_source']}); plan in {root}")
            if plan.get("affordable_count", 0) > plan["count"]:
                print(f"the budget allows about {plan['affordable_count']} spheres (--count) for the same study")
        plan = any_deck.read_plan(root)
        if args.command == "run":
            any_deck.run_study(root, plan, args.celldem)
        if args.command == "analyse":
            paths = any_deck.write_report(root, plan, any_deck.analyse_study(root, plan))
            print("wrote " + ", ".join(paths))
    except (any_deck.StudyError, study_compare.CompareError, binary.BinaryError) as err:
        return error(err)
    return 0


def cmd_compare(args):
    try:
        result = study_compare.compare(args.base, args.other, args.margin)
    except study_compare.CompareError as err:
        return error(err)
    print(study_compare.markdown(result))
    if args.json:
        study_runs.write_json(args.json, result)
    return 0


def cmd_floors(args):
    try:
        result = study_floors.study(args.root, decks.load(), [int(n) for n in args.counts.split(",")], args.seeds,
                                    args.celldem)
    except (study_floors.FloorsError, OSError) as err:
        return error(err)
    print(study_floors.markdown(result))
    print(f"wrote {os.path.join(args.root, 'floors.json')} and floors.md")
    return 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    for name in ("plan", "run", "analyse"):
        p = sub.add_parser(name)
        p.add_argument("--root", dest="root_given", help="study results folder (default results/study, with --deck "
                       "results/study-<deck name>)")
        p.add_argument("--deck", help="study this deck instead of the paper's reduced scene")
        p.add_argument("--budget-core-hours", type=float, help="with --deck: the core-hours the study may take")
        p.add_argument("--count", type=int, default=any_deck.DEFAULT_COUNT,
                       help="with --deck: spheres of the reduced scene (default 1000, at most the deck's)")
        p.add_argument("--throughput", type=float,
                       help="with --deck: particle-steps per core-second for the budget (default: measured by the "
                       "study's runs so far, else celldem plan's figure)")
        p.add_argument("--celldem", default=binary.find(),
                       help="celldem binary (default $CELLDEM, else build/celldem)")
        if name == "run":
            p.add_argument("--jobs", type=int, default=1, help="runs at once (default 1), each single-threaded")
            p.add_argument("--only", nargs="*", help="groups or run names to run (their samples come along)")
            p.add_argument("--max-priority", type=int, help="only runs of this priority or more important")
            p.add_argument("--order", choices=("priority", "cost"), default="priority",
                           help="most important first (default) or longest first (for --jobs > 1)")
            p.add_argument("--stop-after", type=float, help="start no run after this many seconds")
            p.add_argument("--hard-stop", type=float, help="stop running runs after this many seconds (they resume)")
            p.add_argument("--retry-failed", action="store_true", help="run again the runs that failed")
        if name == "analyse":
            p.add_argument("--write-presets", action="store_true", help="write inputs/fast.json, inputs/balanced.json")
            p.add_argument("--write-rules", nargs="?", const=study_runs.RULES_PATH, metavar="PATH",
                           help="write the time-to-answer rules of `celldem --tolerance` (default "
                                "solver/io/time_to_answer_rules.json)")
    p = sub.add_parser("compare", help="two ensembles of one deck on the same seeds, quantity by quantity")
    p.add_argument("base", help="the BASE ensemble folder (its seed-to-seed spread is the floor)")
    p.add_argument("other", help="the OTHER ensemble folder (same deck and seeds, other settings)")
    p.add_argument("--margin", type=float, default=study_compare.MARGIN_FLOORS,
                   help="equivalence margin of TOST in floors (default 1)")
    p.add_argument("--json", help="also write the comparison to this file")
    p = sub.add_parser("floors", help="the noise floor against the particle count (--tolerance's floor model)")
    p.add_argument("--counts", default=",".join(str(n) for n in study_floors.DEFAULT_COUNTS),
                   help="particle counts, comma-separated (default 500,1000,2000)")
    p.add_argument("--seeds", default=study_floors.DEFAULT_SEEDS, help="seeds of each ensemble (default 1-8)")
    p.add_argument("--root", default=os.path.join("results", "study-floors"), help="results folder")
    p.add_argument("--celldem", default=binary.find(), help="celldem binary (default $CELLDEM, else build/celldem)")
    args = parser.parse_args(argv)
    if args.command == "compare":
        return cmd_compare(args)
    if args.command == "floors":
        args.celldem, args.root = os.path.abspath(args.celldem), os.path.abspath(args.root)
        return cmd_floors(args)
    args.celldem = os.path.abspath(args.celldem)
    if args.deck:
        return cmd_any_deck(args)
    args.root = os.path.abspath(args.root_given or DEFAULT_ROOT)
    if args.command in ("plan", "run"):  # the plan places its time steps by the paper deck's critical step
        try:
            args.paper_plan = binary.plan(decks.PAPER_DECK, args.celldem)
        except binary.BinaryError as err:
            return error(err)
    return {"plan": cmd_plan, "run": cmd_run, "analyse": cmd_analyse}[args.command](args)


if __name__ == "__main__":
    sys.exit(main())
