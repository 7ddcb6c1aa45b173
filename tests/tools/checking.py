"""For the Python snippets of test_tools.sh and test_study.sh (common.sh puts this folder on PYTHONPATH): collect
the failures, print them all, exit non-zero when there are any."""

import math
import sys

errors = []


def error(message):
    errors.append(message)


def check(what, got, want, tol=1e-12):
    """got == want; for a finite float want, within tol relative (absolute below 1)."""
    if isinstance(want, float) and math.isfinite(want):
        ok = got is not None and abs(got - want) <= tol * max(1, abs(want))
    else:
        ok = got == want
    if not ok:
        error(f"{what}: got {got!r}, want {want!r}")


def done():
    for e in errors:
        print("  " + e, file=sys.stderr)
    sys.exit(1 if errors else 0)
