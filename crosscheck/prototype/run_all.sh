#!/bin/bash
# Reproduce every number in NOTES.md (about 5 min on 2 cores). Outputs go to runs/.
set -e
cd "$(dirname "$0")"
PY=/usr/bin/python3
MPI="mpirun --allow-run-as-root -np 2"
mkdir -p runs && cd runs

# 1. scene: sparse grid -> frictionless isotropic compression to ~100 kPa (LAMMPS)
$PY ../gen_scene.py sparse.data                       # 512 spheres, 16 sizes
lmp -in ../in.prep.lmp -var IN sparse.data -var OUT dense.data -var P0 1e5 -log prep.log -screen none
$PY ../check_stress.py dense.data                     # independent stress / contact count

# 2. unit checks: velocity layout + drag coefficients, two-sphere remap test
$PY ../gen_scene.py spin.data --n 3 --spin 0.01 --seed 5
for m in viscous langevin; do lmp -in ../checks/in.dampcheck.lmp -var mode $m -log none -screen none
  $PY ../check_damp.py $m; done
liggghts -in ../checks/in.dampcheck.lig -log none -screen none; $PY ../check_damp.py ligviscous
cp ../checks/two.data . && for R in x v; do lmp -in ../checks/in.two.lmp -var R $R -log none -screen none
  echo "remap $R:"; tail -1 dump.twoa.$R; done

# 3. tests (a) strain control, (b) TTC servo; both codes; 1 and 2 ranks
P="KN=1e6 KT=1e6 MU=0.5 DT=1e-6 ALPHA=0.05 OUT_EVERY=100 NSTEPS=20000 PDAMP=1e-5 MODULUS=1e8"
A="AX1=strain:2e-7 AX2=strain:0 AX3=strain:0"
B="AX1=strain:2e-7 AX2=stress:1e5 AX3=stress:1e5"
for t in a b; do
  eval AX=\$$(echo $t | tr ab AB)
  for code in lammps liggghts; do
    ext=$([ $code = lammps ] && echo lmp || echo lig); exe=$([ $code = lammps ] && echo lmp || echo liggghts)
    $PY ../render.py ../template.$code.in dense.data in.$t.$ext $P $AX OUT=$t.$ext.csv
    $PY ../render.py ../template.$code.in dense.data in.$t.np2.$ext $P $AX OUT=$t.$ext.np2.csv
    $exe -in in.$t.$ext -log $t.$ext.log -screen none
    $MPI $exe -in in.$t.np2.$ext -log $t.$ext.np2.log -screen none
    echo "== $t $code np1 vs np2"; $PY ../compare.py $t.$ext.csv $t.$ext.np2.csv
  done
  $PY ../render.py ../template.lammps.in dense.data in.${t}v.lmp $P $AX OUT=${t}v.lmp.csv REMAP=v
  lmp -in in.${t}v.lmp -log ${t}v.lmp.log -screen none
done
$PY ../summarize.py a.lmp.csv a.lig.csv av.lmp.csv b.lmp.csv b.lig.csv bv.lmp.csv
grep -H "Loop time" *.log

# 4. servo lag versus PDAMP (LAMMPS press/berendsen)
for pd in 1e-3 1e-4 1e-5 1e-6 2.5e-7; do
  $PY ../render.py ../template.lammps.in dense.data in.b$pd.lmp $P $B PDAMP=$pd OUT=b$pd.lmp.csv
  lmp -in in.b$pd.lmp -log b$pd.lmp.log -screen none
done
$PY ../summarize.py b*e-*.lmp.csv
