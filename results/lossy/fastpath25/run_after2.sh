#!/bin/sh
# After the palette change (commit 511fa6e): this branch alone on the three sets of
# run_bench.sh (label after2, against the before rows of main already in each decode.csv),
# then main against this branch in one process pair on the cells whose quantised voxels
# take a fast-codec palette.
set -e
cd "$(dirname "$0")/../../.."
R=results/lossy/fastpath25
run() {
    PYTHONPATH=$PWD /work/venv/bin/python scripts/bench_lossy_decode.py --datasets $1 --effort fast \
        --profile --rounds $2 --label after2 --out $3 > $3/after2.log 2>&1
    uptime >> $3/after2.log
}
run ct_head,tgv_u,cam_t,md_water,eta_u,xray_1jzv 7 $R
run storm_p,mecca_t,sst_monthly,uas_monthly,seam_ps,cam_v,contour_t,grid3d_var3,mri_inia19_float 5 $R/heldout
run sea_ice,tas_monthly,hgt_500,contour_z 5 $R/heldout25
PYTHONPATH=$PWD /work/venv/bin/python scripts/bench_lossy_ab.py --trees main=/work/main,branch=$PWD \
    --datasets md_water,mecca_t,seam_ps,eta_u,storm_p --rels 1e-2,1e-3,1e-4,1e-5 --rounds 7 \
    --effort fast --out $R/ab_palette > $R/ab_palette.log 2>&1
uptime >> $R/ab_palette.log
