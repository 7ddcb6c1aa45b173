# Sourced by the tests in this folder: ROOT (the checkout), PY (a python3 that sees numpy and matplotlib: Debian's,
# unless CELLDEM_PYTHON says otherwise), TMP (removed on exit) and fail MESSAGE.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
PY="${CELLDEM_PYTHON:-/usr/bin/python3}"
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT

fail() { echo "FAIL: $*" >&2; exit 1; }

# The snippets import checking.py (this folder) and the tools' package (tools/celldem).
export PYTHONPATH="$ROOT/tests/tools:$ROOT/tools${PYTHONPATH:+:$PYTHONPATH}"
