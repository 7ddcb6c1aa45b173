"""Roofline of celldem's time step on one core: per particle-step and per kernel, the instructions, flops and bytes
of the paper's TTC shear scene, against the core's measured clock, FMA peak and triad bandwidths.

Usage: /usr/bin/python3 tools/roofline.py [--out results/roofline] [--celldem build/celldem]
                                          [--deck inputs/paper.json] [--state results/paper/prepared.state]
                                          [--copies 8] [--force]

Writes OUT/roofline.json (every number with its unit and how it was obtained), OUT/roofline.md (the table) and
OUT/roofline.png (the roofline plot); raw outputs (callgrind files, benches, perf data) in OUT/raw. Needs valgrind,
objdump and g++ (perf, for the kernels' time shares, where it works). Everything runs on one thread; about
2.5 minutes (--copies 0 skips the cache simulation of the larger sample: about 1.5 minutes less).
Method: tools/celldem/performance/roofline.py.
"""

import argparse
import os
import sys
import time

from celldem import binary
from celldem.performance import roofline


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join(binary.REPO, "results", "roofline"), help="output folder")
    parser.add_argument("--celldem", default=None, help="celldem binary (default $CELLDEM, else build/celldem)")
    parser.add_argument("--deck", default=os.path.join(binary.REPO, "inputs", "paper.json"), help="deck of the scene")
    parser.add_argument("--state", default=os.path.join(binary.REPO, "results", "paper", "prepared.state"),
                        help="prepared sample to start from")
    parser.add_argument("--callgrind-steps", type=int, default=roofline.CALLGRIND_STEPS,
                        help=f"steps under callgrind (default {roofline.CALLGRIND_STEPS})")
    parser.add_argument("--callgrind-warmup", type=int, default=roofline.CALLGRIND_WARMUP,
                        help=f"uninstrumented steps before them (default {roofline.CALLGRIND_WARMUP}): the skin adapts")
    parser.add_argument("--bench-steps", type=int, default=roofline.BENCH_STEPS,
                        help=f"steps of the native bench (default {roofline.BENCH_STEPS})")
    parser.add_argument("--bench-warmup", type=int, default=roofline.BENCH_WARMUP,
                        help=f"warm-up steps of the native bench (default {roofline.BENCH_WARMUP})")
    parser.add_argument("--bench-repeats", type=int, default=roofline.BENCH_REPEATS,
                        help=f"repeats of the native bench (default {roofline.BENCH_REPEATS})")
    parser.add_argument("--copies", type=int, default=roofline.LARGE_COPIES,
                        help=f"periodic copies for the larger sample's cache simulation (default "
                             f"{roofline.LARGE_COPIES}; 0 skips it)")
    parser.add_argument("--force", action="store_true", help="overwrite an earlier roofline.json in --out")
    args = parser.parse_args(argv)

    def fail(message):
        print(f"roofline.py: error: {message}", file=sys.stderr)
        return 2

    out = os.path.abspath(args.out)
    if os.path.exists(os.path.join(out, "roofline.json")) and not args.force:
        return fail(f"{out}/roofline.json exists (give --force to overwrite it)")
    celldem = binary.find(args.celldem)
    if not os.access(celldem, os.X_OK):
        return fail(f"no celldem binary at {celldem} (build it with tools/build.sh, or give --celldem)")
    for what, path in (("deck", args.deck), ("state", args.state)):
        if not os.path.isfile(path):
            return fail(f"no {what} at {path}")
    if min(args.callgrind_steps, args.bench_steps, args.bench_repeats) < 1 or min(args.bench_warmup,
                                                                                  args.callgrind_warmup) < 0:
        return fail("--callgrind-steps, --bench-steps and --bench-repeats must be at least 1, --bench-warmup and "
                    "--callgrind-warmup >= 0")
    try:
        roofline.require(("valgrind", "objdump", "g++"))
        os.makedirs(out, exist_ok=True)
        start = time.monotonic()
        paths = roofline.measure_into(out, celldem, os.path.abspath(args.deck), os.path.abspath(args.state),
                                      callgrind_steps=args.callgrind_steps, bench_steps=args.bench_steps,
                                      bench_warmup=args.bench_warmup, bench_repeats=args.bench_repeats,
                                      copies=args.copies, callgrind_warmup=args.callgrind_warmup)
    except roofline.RooflineError as err:
        return fail(str(err))
    print(f"wrote {', '.join(map(str, paths))} in {time.monotonic() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
