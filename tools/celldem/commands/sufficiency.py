"""Model sufficiency of a deck: which sub-models and model terms change its results beyond the seed-to-seed noise.

Usage: celldem-sufficiency DECK (or /usr/bin/python3 tools/sufficiency.py DECK) --out DIR [--seeds 4] [--count 300] [--end-strain 0.04]
                                             [--jobs 2] [--margin 1] [--switches KEY,...] [--analyse-only]

Runs DECK on a reduced scene (--count spheres, tests to ε1 = --end-strain, everything else the deck's) over
--seeds seeds as it is and with each sub-model or term switched one step simpler, one at a time (hertz → linear,
mindlin → linear_history, rolling sds → none, twisting marshall → none, rotational damping → 0, kinematics
affine → lammps; switches the deck does not use are listed as skipped), and writes DIR/sufficiency.json and
DIR/sufficiency.md: per switch and compared quantity (summary.json's peak σ1/σ3, ε1 at the peak, εv and Z at the
end, b at the peak of non-axisymmetric tests), the paired change per seed in noise units, its paired t-test with
Holm's adjustment over the switch's quantities, its equivalence test (TOST at 2.5 %) within --margin noise floors
taken at the floor's lower 97.5 % confidence limit (chi-square; the floor comes from the same few seeds), so that a
true change of --margin floors is called "not needed" at most 5 % of the time (measured 0.4 % with 4 seeds), the
smallest change detectable at 80 % power, and a verdict: needed, not needed or undecided at n seeds.
--switches round_off adds a calibration switch that changes nothing physical (time_step × (1 + 1e-9)).
Resumable: runs with an outcome.json are not run again (runs of another deck or scene in DIR are removed).
tools/study.py analyse includes DIR/sufficiency.md in the study's report when DIR (named sufficiency*) lies beside
the study's results folder. Method: tools/celldem/study/sufficiency.py.
"""

import argparse
import os
import sys

from celldem import binary, decks
from celldem.study import sufficiency


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("deck", help="the deck (JSON)")
    parser.add_argument("--out", required=True, help="results folder")
    parser.add_argument("--seeds", type=int, default=len(sufficiency.DEFAULT_SEEDS),
                        help=f"seeds 1..N (default {len(sufficiency.DEFAULT_SEEDS)}; at least 2)")
    parser.add_argument("--count", type=int, default=sufficiency.DEFAULT_COUNT,
                        help=f"spheres of the reduced scene (default {sufficiency.DEFAULT_COUNT})")
    parser.add_argument("--end-strain", type=float, default=sufficiency.DEFAULT_END_STRAIN,
                        help=f"end strain of the reduced tests (default {sufficiency.DEFAULT_END_STRAIN:g})")
    parser.add_argument("--jobs", type=int, default=2, help="runs at once, each single-threaded (default 2)")
    parser.add_argument("--margin", type=float, default=sufficiency.MARGIN_FLOORS,
                        help="noise floors within which a change counts as none (TOST within the floor's lower "
                             "97.5 %% confidence limit; default "
                             f"{sufficiency.MARGIN_FLOORS:g})")
    keys = [k for k, _ in sufficiency.SWITCHES + sufficiency.CALIBRATION_SWITCHES]
    parser.add_argument("--switches", default=None,
                        help=f"comma-separated switches to run (default: all physical ones; known: {', '.join(keys)})")
    parser.add_argument("--analyse-only", action="store_true", help="write the tables from the runs there are")
    parser.add_argument("--celldem", default=binary.find(),
                        help="celldem binary (default $CELLDEM, else build/celldem)")
    args = parser.parse_args(argv)
    if args.seeds < 2:
        parser.error("--seeds must be at least 2 (the noise floor is a standard deviation over seeds)")
    celldem = os.path.abspath(args.celldem)
    root = os.path.abspath(args.out)
    try:
        deck = decks.load(args.deck)
    except (OSError, ValueError) as err:
        print(f"sufficiency.py: error: cannot read {args.deck}: {err}", file=sys.stderr)
        return 2
    deck_ends = [t["end"]["strain"] for t in deck.get("tests", []) if "strain" in (t.get("end") or {})]
    reduced = sufficiency.reduce_deck(deck, args.count, args.end_strain)
    chosen = None
    if args.switches:
        chosen = [k.strip() for k in args.switches.split(",") if k.strip()]
        unknown = [k for k in chosen if k not in keys]
        if unknown:
            parser.error(f"--switches: unknown {', '.join(unknown)} (known: {', '.join(keys)})")
    try:
        configs = sufficiency.variants(reduced, celldem, chosen)
    except binary.BinaryError as err:
        print(f"sufficiency.py: error: {err}", file=sys.stderr)
        return 2
    seeds = tuple(range(1, args.seeds + 1))
    scene = {"count": args.count, "end_strain": args.end_strain, "deck_count": deck["sample"]["count"],
             "deck_end_strains": deck_ends}
    if not args.analyse_only:
        sufficiency.run(root, reduced, configs, seeds, celldem, args.jobs)
    deck_name = os.path.relpath(os.path.abspath(args.deck), binary.REPO) \
        if os.path.abspath(args.deck).startswith(binary.REPO + os.sep) else args.deck
    result = sufficiency.analyse(root, deck_name, reduced, configs, seeds, scene, args.margin)
    md = sufficiency.write(root, result)
    print(f"wrote {md}, {os.path.join(root, 'sufficiency.json')}")
    for r in result["rows"]:
        if r["key"] != "baseline":
            extra = f": {', '.join(r['needed_for'])}" if r.get("needed_for") else ""
            print(f"  {r['label']}: {r['verdict']}{extra}")
    return 1 if result["failed"] else 0


if __name__ == "__main__":
    sys.exit(main())
