"""Two celldem binaries timed against each other: `celldem bench` (one thread, the shear phase of a deck's test) of
both at once, each pinned to a core of its own, then with the cores swapped, in each round; the verdict on new
over old with its test and interval (method: tools/celldem/performance/paired.py). With --whole-process, whole
`celldem run DECK` processes (one thread, start-up and every write included) instead, timed by the wall clock.

Usage: /usr/bin/python3 tools/compare_binaries.py OLD NEW [--rounds 8] [--steps 4000] [--warmup 1000]
                                                  [--deck inputs/paper.json] [--state results/paper/prepared.state]
                                                  [--whole-process] [--bar 1.05] [--json FILE]

Needs two cores and nothing else running: each round takes both. Exit 0 with the verdict printed (and written to
--json), 2 on bad input or a failed bench.
"""

import argparse
import json
import os
import sys

from celldem import binary
from celldem.performance import paired


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("old", help="the binary to compare against")
    parser.add_argument("new", help="the binary being judged")
    parser.add_argument("--rounds", type=int, default=8, help="rounds of two halves (default 8; at least 2)")
    parser.add_argument("--steps", type=int, default=4000, help="timed steps of each bench (default 4000)")
    parser.add_argument("--warmup", type=int, default=1000, help="untimed steps before them (default 1000)")
    parser.add_argument("--deck", default=os.path.join(binary.REPO, "inputs", "paper.json"), help="deck of the scene")
    parser.add_argument("--state", default=os.path.join(binary.REPO, "results", "paper", "prepared.state"),
                        help="prepared sample to start from")
    parser.add_argument("--whole-process", action="store_true",
                        help="time whole `celldem run DECK` processes (1 / wall seconds) instead of the bench")
    parser.add_argument("--bar", type=float, default=paired.BAR,
                        help=f"the gain the interval's lower end must clear (default {paired.BAR})")
    parser.add_argument("--json", default=None, help="also write the verdict and every round here")
    args = parser.parse_args(argv)

    def fail(message):
        print(f"compare_binaries.py: error: {message}", file=sys.stderr)
        return 2

    for what, path in (("old", args.old), ("new", args.new)):
        if not (os.path.isfile(path) and os.access(path, os.X_OK)):
            return fail(f"no executable {what} binary at {path}")
    for what, path in (("deck", args.deck), ("state", args.state)) if not args.whole_process else (("deck", args.deck),):
        if not os.path.isfile(path):
            return fail(f"no {what} at {path}")
    if args.rounds < 2:
        return fail(f"--rounds must be at least 2 (a verdict needs a spread), got {args.rounds}")
    if args.steps < 1 or args.warmup < 0:
        return fail("--steps must be at least 1 and --warmup at least 0")
    if not args.bar > 0:
        return fail(f"--bar must be positive, got {args.bar}")
    if args.json and os.path.exists(args.json):
        return fail(f"{args.json} exists (remove it first)")
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
        with open(args.json, "w") as f:
            json.dump({**verdict.as_dict(), "rounds_detail": rounds, "old": os.path.abspath(args.old),
                       "new": os.path.abspath(args.new), "whole_process": args.whole_process, "steps": args.steps, "warmup": args.warmup,
                       "deck": args.deck, "state": args.state}, f, indent=1)
            f.write("\n")
    return 0
