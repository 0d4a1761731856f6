#!/bin/sh
# The decode benchmark of the fastbins24 README section, one core: main's volpack
# (before) and this branch's (after) on the six tuning fields and the nine held-out
# ones. `run_bench.sh after` runs the branch's alone (the reruns of the README).
set -e
cd "$(dirname "$0")/../../.."
PY=/work/venv/bin/python
OUT=results/lossy/fastbins24
SIX=ct_head,tgv_u,cam_t,md_water,eta_u,xray_1jzv
NINE=storm_p,mecca_t,sst_monthly,uas_monthly,seam_ps,cam_v,contour_t,grid3d_var3,mri_inia19_float
for label in ${1:-before after}; do
    code=$PWD
    [ "$label" = before ] && code=/work/main
    PYTHONPATH=$code $PY scripts/bench_lossy_decode.py --datasets $SIX --effort fast --profile \
        --rounds 7 --label $label --out $OUT > $OUT/$label.log 2>&1
    PYTHONPATH=$code $PY scripts/bench_lossy_decode.py --datasets $NINE --effort fast --profile \
        --rounds 5 --label $label --out $OUT/heldout > $OUT/heldout_$label.log 2>&1
done
echo done > $OUT/bench.done
