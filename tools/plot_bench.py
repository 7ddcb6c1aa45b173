#!/usr/bin/python3
"""`celldem-plot-bench` from a checkout: tools/celldem/commands/plot_bench.py (`/usr/bin/python3 tools/plot_bench.py --help`)."""

import sys

from celldem.commands.plot_bench import main

if __name__ == "__main__":
    sys.exit(main())
