#!/usr/bin/python3
"""`celldem-study` from a checkout: tools/celldem/commands/study.py (`/usr/bin/python3 tools/study.py --help`)."""

import sys

from celldem.commands.study import main

if __name__ == "__main__":
    sys.exit(main())
