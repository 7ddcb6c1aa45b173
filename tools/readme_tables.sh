#!/usr/bin/env bash
# The documentation's generated tables come from the tables in the code: the deck keys
# (`celldem schema --markdown`, in docs/deck.md) and the series columns (`celldem schema --series --markdown`,
# in docs/outputs.md). Each lies between a `<!-- generated: deck keys -->` or `<!-- generated: series columns -->`
# marker and `<!-- end generated -->`, in README.md or any docs/*.md page; each marker must appear exactly once.
# Usage: tools/readme_tables.sh CELLDEM [--check]   (without --check: rewrite the pages in place)
set -euo pipefail
cd "$(dirname "$0")/.."
celldem=${1:?usage: tools/readme_tables.sh CELLDEM [--check]}
mode=${2:-write}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$celldem" schema --markdown > "$tmp/keys"
"$celldem" schema --series --markdown > "$tmp/columns"
pages=(README.md docs/*.md)
status=0
for marker in "deck keys" "series columns"; do
  n=$(cat "${pages[@]}" | grep -c -- "<!-- generated: $marker -->" || true)
  if [[ $n != 1 ]]; then
    echo "the marker <!-- generated: $marker --> appears $n times in ${pages[*]} (must be once)" >&2
    status=1
  fi
done
for page in "${pages[@]}"; do
  # Replace what lies between each pair of markers with the generated table.
  awk -v keys="$tmp/keys" -v columns="$tmp/columns" '
    /<!-- generated: deck keys -->/ { print; while ((getline l < keys) > 0) print l; skip = 1; next }
    /<!-- generated: series columns -->/ { print; while ((getline l < columns) > 0) print l; skip = 1; next }
    /<!-- end generated -->/ { skip = 0 }
    !skip { print }' "$page" > "$tmp/page"
  if [[ $mode == --check ]]; then
    if ! diff -u "$page" "$tmp/page"; then
      echo "$page's generated tables are stale: run bash tools/readme_tables.sh build/celldem" >&2
      status=1
    fi
  elif ! cmp -s "$page" "$tmp/page"; then
    cp "$tmp/page" "$page"
    echo "rewrote $page"
  fi
done
exit $status
