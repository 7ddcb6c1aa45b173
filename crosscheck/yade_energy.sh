#!/usr/bin/env bash
# celldem's energy budget against YADE's O.energy on one small packing with the same physics (docs/energy.md):
# 216 equal spheres (YADE's FrictPhys then has celldem's kn and kt), prepared by celldem, then one strain-driven
# test without damping in both codes (axis 1 shortened at a fixed rate, axes 2 and 3 held), friction 0.5.
# Needs yade (Debian package `yade`); not part of the test suite. Usage: crosscheck/yade_energy.sh CELLDEM [OUT]
set -euo pipefail
celldem="$(realpath "$1")"
out="${2:-$(mktemp -d)}"
here="$(cd "$(dirname "$0")" && pwd)"
mkdir -p "$out"
cd "$out"
steps=20000
cat > prep.json <<JSON
{"format":1,"sample":{"count":216,"diameters":{"list":[0.004]},"density":2650,"seed":5,
 "grid_spacing":0.005},"contact":{"kn":1e6,"kt":1e6},"damping":{"translational":0.05,"rotational":0.05},
 "time_step":1e-6,"prepare":{"target_pressure":1e5,"fast_strain_increment":5e-5,"output_interval":1000,
 "equilibrium":{"min_steps":2000,"max_steps":300000,"unbalanced_force_ratio":0.01,"check_interval":500}}}
JSON
"$celldem" run prep.json --out prep --force --quiet --threads 1
cat > test.json <<JSON
{"format":1,"sample":{"count":216,"diameters":{"list":[0.004]},"density":2650,"seed":5,
 "grid_spacing":0.005},"contact":{"kn":1e6,"kt":1e6},"damping":{"translational":0,"rotational":0},
 "time_step":1e-6,"energy_budget":true,"initial_state":"prep/prepared.state",
 "tests":[{"name":"strain","friction":0.5,"dynamic":true,
   "axes":{"x1":{"strain_increment":2e-7},"x2":{"strain_increment":0},"x3":{"strain_increment":0}},
   "end":{"axis":"x1","steps":$steps},"output_interval":1000,"snapshots":{"interval":$steps,"format":"ascii"}}]}
JSON
"$celldem" run test.json --out test --force --quiet --threads 1
/usr/bin/python3 "$here/yade_packing.py" test $steps > packing.json
yade -x -n "$here/yade_energy.py" packing.json yade.json > yade.log 2>&1 || { tail -20 yade.log; exit 1; }
/usr/bin/python3 "$here/yade_packing.py" --compare test yade.json
