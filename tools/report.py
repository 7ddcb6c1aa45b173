#!/usr/bin/python3
"""`celldem-report` from a checkout: tools/celldem/commands/report.py (`/usr/bin/python3 tools/report.py --help`)."""

import sys

from celldem.commands.report import main

if __name__ == "__main__":
    sys.exit(main())
