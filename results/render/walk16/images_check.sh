#!/bin/bash
# 12-frame orbits, -j 1 and default threads, both vpks, main against branch: every PNG
# compared (usage: images_check.sh MAIN_PYTHONPATH BRANCH_PYTHONPATH)
export VOLPACK_CACHE_DIR=/work/cache/walk16
declare -A TREES=([main]=$1 [branch]=$2)
for v in mri_ch2better ct_head; do
  for j in "-j 1" ""; do
    for t in main branch; do
      d=/tmp/w16_img/$t/$v${j// /}
      rm -rf $d; mkdir -p $d
      (cd /tmp && PYTHONPATH=${TREES[$t]} /work/venv/bin/python -m volpack walk /work/cache/walk14/$v.vpk $d/ --orbit 12 $j --json > $d.json) || echo FAIL $t $v $j
    done
    a=/tmp/w16_img/main/$v${j// /}; b=/tmp/w16_img/branch/$v${j// /}
    n=0; same=0
    for f in $a/*.png; do n=$((n+1)); cmp -s $f $b/$(basename $f) && same=$((same+1)); done
    echo "$v ${j:-default}: $same of $n PNGs equal ($(ls $b/*.png | wc -l) in branch)"
  done
done
