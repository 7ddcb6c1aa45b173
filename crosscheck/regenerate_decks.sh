#!/usr/bin/env bash
# Regenerates crosscheck/decks/: the LAMMPS and LIGGGHTS scripts of the paper deck's tests and preparation, written by
# `celldem translate --no-data` (they depend on the deck only), and the warnings it prints for each code.
# The data file is not kept here: make it from a prepared state with
#   celldem translate inputs/paper.json --to lammps --state results/paper/prepared.state --out DIR
# usage: crosscheck/regenerate_decks.sh [CELLDEM] [OUT_DIR]     (default: build/celldem, crosscheck/decks)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
celldem=$(realpath "${1:-$root/build/celldem}")
out=$(realpath -m "${2:-$root/crosscheck/decks}")
cd "$root"  # the deck is named by its relative path, so the scripts do not depend on the checkout's location
mkdir -p "$out"
for code in lammps liggghts; do
  "$celldem" translate inputs/paper.json --to "$code" --no-data --out "$out" --force \
    > /dev/null 2> "$out/warnings.$code.txt"
done
