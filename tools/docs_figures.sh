#!/usr/bin/env bash
# The README's pictures, copied (and scaled down) into docs/figures/ from fresh runs. The small deck
# (tests/run/small_run.json, 150 spheres: seconds) is run here into results/small/; produce the others first:
#   bash tools/paper.sh                                              -> results/paper/figures/overview.png
#   build/celldem run inputs/paper.json --out results/paper-ensemble --seeds 1-8 && tools/report.py results/paper-ensemble
#   build/celldem run inputs/failure_surface.json --out results/failure_surface
#   /usr/bin/python3 tools/failure_surface.py results/failure_surface --with results/paper
#   /usr/bin/python3 tools/study.py run && /usr/bin/python3 tools/study.py analyse   (hours: optional)
#   build/celldem bench --scaling --out results/bench-scaling && /usr/bin/python3 tools/plot_bench.py results/bench-scaling
#   /usr/bin/python3 tools/roofline.py                               -> results/roofline/roofline.png (minutes)
#   crosscheck/run_crosscheck.py ... (crosscheck/README.md; its reports are kept in crosscheck/reports/)
# then: bash tools/docs_figures.sh. A picture whose run is missing is left as it is (and named).
set -euo pipefail
cd "$(dirname "$0")/.."
out=docs/figures
mkdir -p "$out"
copy() {  # source destination-name
  if [[ -f $1 ]]; then
    /usr/bin/python3 - "$1" "$out/$2" <<'PY'
import sys
from PIL import Image  # comes with Debian's matplotlib
img = Image.open(sys.argv[1]).convert("RGB")
img.thumbnail((900, 900))  # small PNGs: at most 900 pixels a side, 256 colours
img.quantize(colors=256, method=Image.Quantize.MEDIANCUT).save(sys.argv[2], optimize=True)
PY
    echo "docs/figures/$2 <- $1"
  else
    echo "docs/figures/$2: $1 is missing (run it first; the old picture, if any, is kept)"
  fi
}
if [[ -x build/celldem ]]; then
  build/celldem run tests/run/small_run.json --out results/small --force --quiet --threads 1
  /usr/bin/python3 tools/report.py results/small --refresh-figures >/dev/null
fi
copy results/small/figures/overview.png small_overview.png
copy results/small/figures/force_chains.png small_force_chains.png
copy results/small/figures/prepare.png small_prepare.png
copy results/paper/figures/overview.png paper_overview.png
copy results/paper/figures/force_chains.png paper_force_chains.png
copy results/paper-ensemble/figures/overview.png paper_ensemble_overview.png
copy results/failure_surface/figures/failure_surface_phi_b.png failure_surface_phi_b.png
copy results/failure_surface/figures/failure_surface_pi_plane.png failure_surface_pi_plane.png
copy results/study/figures/pareto.png study_pareto.png
copy results/study/figures/stability.png study_stability.png
copy crosscheck/reports/paper-lammps/ttc.png crosscheck_lammps_ttc.png
copy crosscheck/reports/paper-lammps/psc.png crosscheck_lammps_psc.png
copy results/bench-scaling/scaling.png bench_scaling.png
copy results/roofline/roofline.png roofline.png
