#!/bin/bash
# fresh-process frame 0 of `volpack walk V --orbit 1 --json`: select/decode/render CPU ms (process, all threads) and walls
export VOLPACK_CACHE_DIR=/work/cache/walk15
v=${1:-mri_ch2better}; n=${2:-4}
uptime
for r in $(seq $n); do
  for t in main branch; do
    d=/tmp/w15_f0/$t; rm -rf $d; mkdir -p $d
    (cd /tmp && PYTHONPATH=/tmp/w15_$t /work/venv/bin/python -m volpack walk /work/cache/walk15/$v.vpk $d/ --orbit 1 --json 2>/dev/null) | /work/venv/bin/python -c "
import json,sys; f=json.load(sys.stdin)['per_frame'][0]; c=f['cpu_s']
print('$t r$r', 'cpu select/decode/render %.0f/%.0f/%.0f = %.0f' % tuple([1e3*x for x in c] + [1e3*sum(c)]), 'wall %.0f/%.0f/%.0f = %.0f' % (1e3*f['select_s'], 1e3*f['decode_s'], 1e3*f['render_s'], 1e3*(f['select_s']+f['decode_s']+f['render_s'])))"
  done
done
uptime
