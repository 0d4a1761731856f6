#!/bin/sh
# Before/after of a PSNR target's file on each FIELD: sh run_ab.sh BASE_CHECKOUT FIELD.npy...
# (the "after" side is this checkout; kernel caches kept apart so neither recompiles).
base=$1; shift
here=$(cd "$(dirname "$0")/../../.." && pwd)
for f in "$@"; do
  for side in before after; do
    if [ $side = before ]; then P=$base; else P=$here; fi
    PYTHONPATH=$P VOLPACK_CACHE_DIR=${VOLPACK_CACHE_DIR:-/tmp/vpcache}-$side \
      python "$here/results/lossy/lead39/psnr_check.py" "$f" 40 60 80 2>&1 | sed "s/^/$side /"
  done
done
