#!/usr/bin/python3
"""`celldem-sufficiency` from a checkout: tools/celldem/commands/sufficiency.py (`/usr/bin/python3 tools/sufficiency.py --help`)."""

import sys

from celldem.commands.sufficiency import main

if __name__ == "__main__":
    sys.exit(main())
