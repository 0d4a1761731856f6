#!/bin/sh
# qvox26's decode benchmark (README), one core, `--effort fast`: main's volpack (before,
# /work/main) then this branch's (after) on each named set: `six` (the tuning fields),
# `nine` (the held-out ones), `final` (not tuned on, run once at the end: fastpath25's four
# held-out fields and two float fields of scripts/datasets.py that no list names).
# `sh run_bench.sh nine final` runs those two.
set -e
cd "$(dirname "$0")/../../.."
for set in ${*:-six nine final}; do
    case $set in
        six) ds=ct_head,tgv_u,cam_t,md_water,eta_u,xray_1jzv r=7 o=. ;;
        nine) ds=storm_p,mecca_t,sst_monthly,uas_monthly,seam_ps,cam_v,contour_t,grid3d_var3,mri_inia19_float r=5 o=heldout ;;
        final) ds=sea_ice,tas_monthly,hgt_500,contour_z,$FINAL_EXTRA r=5 o=final ;;
    esac
    o=results/lossy/qvox26/$o
    mkdir -p $o
    for label in before after; do
        tree=$PWD
        if [ $label = before ]; then tree=/work/main; fi
        PYTHONPATH=$tree /work/venv/bin/python scripts/bench_lossy_decode.py --datasets $ds \
            --effort fast --profile --rounds $r --label $label --out $o > $o/$label.log 2>&1
        uptime >> $o/$label.log
    done
done
