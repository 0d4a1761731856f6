#!/bin/sh
# The "after" runs again, with the final rule (the first ones are labelled after_sametier).
set -e
cd "$(dirname "$0")/../../.."
PY=/work/venv/bin/python
OUT=results/lossy/fastbins24
SIX=ct_head,tgv_u,cam_t,md_water,eta_u,xray_1jzv
NINE=storm_p,mecca_t,sst_monthly,uas_monthly,seam_ps,cam_v,contour_t,grid3d_var3,mri_inia19_float
PYTHONPATH=$PWD $PY scripts/bench_lossy_decode.py --datasets $SIX --effort fast --profile --rounds 7 --label after --out $OUT > $OUT/after.log 2>&1
PYTHONPATH=$PWD $PY scripts/bench_lossy_decode.py --datasets $NINE --effort fast --profile --rounds 5 --label after --out $OUT/heldout > $OUT/heldout_after.log 2>&1
echo done > $OUT/bench.done
