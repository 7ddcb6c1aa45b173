#!/usr/bin/python3
"""`celldem-figures` from a checkout: tools/celldem/commands/figures.py (`/usr/bin/python3 tools/figures.py --help`)."""

import sys

from celldem.commands.figures import main

if __name__ == "__main__":
    sys.exit(main())
