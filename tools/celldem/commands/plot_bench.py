"""Scaling table and plot from `celldem bench --scaling` output.

Usage: /usr/bin/python3 tools/plot_bench.py BENCH_DIR   (reads BENCH_DIR/bench.json, writes scaling.png and
scaling.md beside it; the work is tools/celldem/performance/bench.py)
"""
import argparse
import sys
from pathlib import Path

from celldem.performance import bench


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[1], epilog=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bench_dir", metavar="BENCH_DIR", help="folder of `celldem bench --scaling --out`")
    folder = Path(parser.parse_args(argv).bench_dir)
    path = folder / "bench.json"
    if not path.is_file():
        print(f"plot_bench: {path} not found (run celldem bench --scaling --out {folder})", file=sys.stderr)
        return 2
    md, png = bench.write_scaling(folder)
    print(f"wrote {md} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
