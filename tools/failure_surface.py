#!/usr/bin/python3
"""`celldem-failure-surface` from a checkout: tools/celldem/commands/failure_surface.py (`/usr/bin/python3 tools/failure_surface.py --help`)."""

import sys

from celldem.commands.failure_surface import main

if __name__ == "__main__":
    sys.exit(main())
