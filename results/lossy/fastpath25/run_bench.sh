#!/bin/sh
# fastpath25's decode benchmark (README), one core, `--effort fast`: main's volpack
# (before, /work/main) then this branch's (after) on each named set: `six` (the tuning
# fields), `nine` (the held-out ones) and `four` (this branch's own held-out fields, run
# once at the end, not tuned on). `sh run_bench.sh nine four` runs those two.
set -e
cd "$(dirname "$0")/../../.."
for set in ${*:-six nine four}; do
    case $set in
        six) ds=ct_head,tgv_u,cam_t,md_water,eta_u,xray_1jzv r=7 o=. ;;
        nine) ds=storm_p,mecca_t,sst_monthly,uas_monthly,seam_ps,cam_v,contour_t,grid3d_var3,mri_inia19_float r=5 o=heldout ;;
        four) ds=sea_ice,tas_monthly,hgt_500,contour_z r=5 o=heldout25 ;;
    esac
    o=results/lossy/fastpath25/$o
    for label in before after; do
        tree=$PWD
        if [ $label = before ]; then tree=/work/main; fi
        PYTHONPATH=$tree /work/venv/bin/python scripts/bench_lossy_decode.py --datasets $ds \
            --effort fast --profile --rounds $r --label $label --out $o > $o/$label.log 2>&1
        uptime >> $o/$label.log
    done
done
