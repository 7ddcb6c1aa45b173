#!/bin/bash
# The rate sweep (1000 spheres, TTC to e1 = 5 %): prepare 2 seeds with the 1x test, then every rung per seed.
# One thread per run (OpenMP's barriers starve on a loaded 2-core machine), nice'd.
B=${CELLDEM:-$(cd "$(dirname "$0")/../.." && pwd)/build/celldem}
cd "$(dirname "$0")/../../results/ladder"  # run tools/ladder/make_decks.py there first
t0=$(date +%s)
/usr/bin/time -f "%e s prep+1x" nice -n 1 $B run ladder_1x_prep.json --out prep --seeds 1-2 --threads 1 --fixed-threads --quiet --force
echo "prep done $(( $(date +%s) - t0 )) s"
for s in 1 2; do
  ( for f in 8 4 2 1.001 1.002 0.5 0.25; do
      /usr/bin/time -f "%e s seed $s rung $f" nice -n 1 $B run ladder_s${s}_$f.json --out r_s${s}_$f --threads 1 --fixed-threads --quiet --force
    done ) &
done
wait
echo "all done $(( $(date +%s) - t0 )) s"
