#!/usr/bin/env bash
# The translated paper decks checked in under crosscheck/decks/ must be what `celldem translate` writes now:
# regenerate them into a temporary folder and compare. Fix a failure with crosscheck/regenerate_decks.sh.
# usage: check_decks_fresh.sh CELLDEM
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bash "$root/crosscheck/regenerate_decks.sh" "$1" "$tmp/decks"
if ! diff -r "$root/crosscheck/decks" "$tmp/decks"; then
  echo "crosscheck/decks is stale: run crosscheck/regenerate_decks.sh and commit the result" >&2
  exit 1
fi
echo "crosscheck/decks is up to date ($(ls "$tmp/decks" | wc -l) files)"
