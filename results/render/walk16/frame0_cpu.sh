#!/bin/bash
# fresh-process frame 0 of `volpack walk V.vpk OUT/ --orbit 1 --json`, trees alternating:
# select/decode/render CPU ms (process, all threads), walls, and the process's user+sys
# seconds and wall (usage: frame0_cpu.sh VPK ROUNDS TREE_NAME=PATH...)
export VOLPACK_CACHE_DIR=/work/cache/walk16
export PYTHONPYCACHEPREFIX=/work/cache/walk16/pyc
unset PYTHONDONTWRITEBYTECODE
v=$1; n=$2; shift 2
echo "# $(basename $v) $(date -u +%H:%M) $(uptime | sed 's/.*load/load/')"
for r in $(seq $n); do
  for tp in "$@"; do
    t=${tp%%=*}; p=${tp#*=}
    d=/tmp/w16_f0/$t; rm -rf $d; mkdir -p $d
    (cd /tmp && PYTHONPATH=$p /usr/bin/time -f "%e %U %S" -o $d.time /work/venv/bin/python -m volpack walk $v $d/ --orbit 1 --json 2>/dev/null) > $d.json
    /work/venv/bin/python -c "
import json,sys; f=json.load(open('$d.json'))['per_frame'][0]; c=f['cpu_s']
w, u, s = open('$d.time').read().split()
print('$t r$r', 'cpu select/decode/render %.0f/%.0f/%.0f = %.0f' % tuple([1e3*x for x in c] + [1e3*sum(c)]), 'wall %.0f/%.0f/%.0f = %.0f' % (1e3*f['select_s'], 1e3*f['decode_s'], 1e3*f['render_s'], 1e3*(f['select_s']+f['decode_s']+f['render_s'])), 'process wall %s user %s sys %s' % (w, u, s))"
  done
done
echo "# $(date -u +%H:%M) $(uptime | sed 's/.*load/load/')"
