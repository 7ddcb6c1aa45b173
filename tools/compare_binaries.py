#!/usr/bin/python3
"""`celldem-compare-binaries` from a checkout: tools/celldem/commands/compare_binaries.py (`/usr/bin/python3 tools/compare_binaries.py --help`)."""

import sys

from celldem.commands.compare_binaries import main

if __name__ == "__main__":
    sys.exit(main())
