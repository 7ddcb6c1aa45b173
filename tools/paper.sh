#!/usr/bin/env bash
# The main job: install what is missing, build, reproduce the paper (prepare + TTC + PSC) into
# results/paper/, then draw its figures and write its report.
# Extra arguments go to `celldem run` (e.g. --resume to continue an interrupted reproduction).
set -euo pipefail
cd "$(dirname "$0")/.."
bash tools/install-deps.sh
CELLDEM_TARGETS=celldem bash tools/build.sh  # the binary only: the test suite is the other command's
out=results/paper
args=("$@")
if [[ ${#args[@]} -eq 0 && -f "$out/progress.json" ]]; then
  # An interrupted reproduction continues where it stopped; a finished one is run afresh.
  finished=$(/usr/bin/python3 -c "
import json
done = set(json.load(open('$out/progress.json')).get('completed', []))
stages = {'prepare'} | {t['name'] for t in json.load(open('inputs/paper.json'))['tests']}
print(int(stages <= done))" 2>/dev/null || echo 0)
  if [[ $finished == 1 ]]; then args=(--force); else args=(--resume); fi
fi
./build/celldem run inputs/paper.json --out "$out" "${args[@]}"
/usr/bin/python3 tools/report.py "$out" --refresh-figures
echo "Figures: $out/figures/  Report: $out/report.md"
