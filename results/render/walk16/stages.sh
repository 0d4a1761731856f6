#!/bin/bash
# frame 0's stages (CPU, wall, system CPU) in a fresh process and a later walk, main and
# branch alternating (usage: stages.sh VPK ROUNDS)
export VOLPACK_CACHE_DIR=/work/cache/walk16
here=$(cd $(dirname $0) && pwd)
for r in $(seq $2); do
  for t in main walk16; do
    echo "== $t round $r $(uptime | sed 's/.*load/load/')"
    (cd /tmp && PYTHONPATH=/work/cache/walk16/trees/$t /work/venv/bin/python $here/stages_sys.py /work/wt/walk16/scripts $1 --repeat 2 --label $t --csv $here/stages_$(basename $1 .vpk).csv)
  done
done
