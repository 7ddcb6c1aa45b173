#!/usr/bin/env bash
# The README's deck-key and series-column tables are generated from the tables in the code
# (`celldem schema --markdown`, `celldem schema --series --markdown`).
# Usage: tools/readme_tables.sh CELLDEM [--check]   (without --check: rewrite README.md in place)
set -euo pipefail
cd "$(dirname "$0")/.."
celldem=${1:?usage: tools/readme_tables.sh CELLDEM [--check]}
mode=${2:-write}
tmp=$(mktemp)
trap 'rm -f "$tmp" "$tmp.keys" "$tmp.columns"' EXIT
"$celldem" schema --markdown > "$tmp.keys"
"$celldem" schema --series --markdown > "$tmp.columns"
# Replace what lies between each pair of markers with the generated table.
awk -v keys="$tmp.keys" -v columns="$tmp.columns" '
  /<!-- generated: deck keys -->/ { print; while ((getline l < keys) > 0) print l; skip = 1; next }
  /<!-- generated: series columns -->/ { print; while ((getline l < columns) > 0) print l; skip = 1; next }
  /<!-- end generated -->/ { skip = 0 }
  !skip { print }' README.md > "$tmp"
if [[ $mode == --check ]]; then
  if ! diff -u README.md "$tmp"; then
    echo "README.md's generated tables are stale: run bash tools/readme_tables.sh build/celldem" >&2
    exit 1
  fi
  grep -q "<!-- generated: deck keys -->" README.md && grep -q "<!-- generated: series columns -->" README.md
else
  cp "$tmp" README.md
fi
