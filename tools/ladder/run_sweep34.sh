#!/bin/bash
# Seeds 3 and 4 of the sweep (no 0.25x rung: time), one thread each, nice'd.
B=${CELLDEM:-$(cd "$(dirname "$0")/../.." && pwd)/build/celldem}
cd "$(dirname "$0")/../../results/ladder"  # run tools/ladder/make_decks.py there first
t0=$(date +%s)
for s in 3 4; do
  ( /usr/bin/time -f "%e s seed $s prep+1x" nice -n 1 $B run ladder_1x_prep.json --out prep_s$s --threads 1 --fixed-threads --quiet --force --seeds $s
    for f in 8 4 2 1.001 1.002 0.5; do
      /usr/bin/time -f "%e s seed $s rung $f" nice -n 1 $B run ladder_s${s}_$f.json --out r_s${s}_$f --threads 1 --fixed-threads --quiet --force
    done ) &
done
wait
echo "all done $(( $(date +%s) - t0 )) s"
