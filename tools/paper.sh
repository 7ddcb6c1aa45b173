#!/usr/bin/env bash
# The main job: install what is missing, build, reproduce the paper (prepare + TTC + PSC) into
# results/paper/, then draw its figures and write its report.
# Extra arguments go to `celldem run` (e.g. --resume to continue an interrupted reproduction).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
bash tools/build.sh
out=results/paper
args=("$@")
if [[ ${#args[@]} -eq 0 ]]; then
  if [[ -f "$out/progress.json" && ! -f "$out/summary.json" ]] || [[ -f "$out/checkpoint.state" ]]; then
    args=(--resume)   # an interrupted reproduction continues where it stopped
  elif [[ -f "$out/summary.json" ]]; then
    args=(--force)
  fi
fi
./build/celldem run inputs/paper.json --out "$out" "${args[@]}"
/usr/bin/python3 tools/report.py "$out" --refresh-figures
echo "Figures: $out/figures/  Report: $out/report.md"
