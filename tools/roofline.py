#!/usr/bin/python3
"""`celldem-roofline` from a checkout: tools/celldem/commands/roofline.py (`/usr/bin/python3 tools/roofline.py --help`)."""

import sys

from celldem.commands.roofline import main

if __name__ == "__main__":
    sys.exit(main())
