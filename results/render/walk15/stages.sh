#!/bin/bash
export VOLPACK_CACHE_DIR=/work/cache/walk15
out=/work/wt/walk15/results/render/walk15/stages
mkdir -p $out
uptime > $out/load.txt
for r in 1 2 3; do
  for t in main branch; do
    (cd /tmp && PYTHONPATH=/tmp/w15_$t /work/venv/bin/python /work/wt/walk15/scripts/profile_walk_first.py /work/cache/walk15/mri_ch2better.vpk --repeat 1 --label $t-r$r --csv $out/ch2better_${t}_r$r.csv > $out/ch2better_${t}_r$r.txt 2>&1)
  done
done
uptime >> $out/load.txt
