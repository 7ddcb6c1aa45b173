#!/usr/bin/env python3
"""Scaling table and plot from `celldem bench --scaling` output.

Usage: /usr/bin/python3 tools/plot_bench.py BENCH_DIR   (reads BENCH_DIR/bench.json, writes scaling.png and
scaling.md beside it; the work is tools/celldem/bench.py)
"""
import os
import sys
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from celldem import bench  # noqa: E402


def main(argv):
    if len(argv) != 2:
        print(__doc__, file=sys.stderr)
        return 2
    folder = Path(argv[1])
    path = folder / "bench.json"
    if not path.is_file():
        print(f"plot_bench: {path} not found (run celldem bench --scaling --out {folder})", file=sys.stderr)
        return 2
    md, png = bench.write_scaling(folder)
    print(f"wrote {md} and {png}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
