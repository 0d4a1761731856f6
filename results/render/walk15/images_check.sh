#!/bin/bash
# 12-frame orbits, -j 1 and default threads, both vpks, main vs branch: every PNG compared
export VOLPACK_CACHE_DIR=/work/cache/walk15
for v in mri_ch2better ct_head; do
  for j in "-j 1" ""; do
    for t in main branch; do
      d=/tmp/w15_img/$t/$v${j// /}
      rm -rf $d; mkdir -p $d
      (cd /tmp && PYTHONPATH=/tmp/w15_$t /work/venv/bin/python -m volpack walk /work/cache/walk15/$v.vpk $d/ --orbit 12 $j --json > $d.json) || echo FAIL $t $v $j
    done
    a=/tmp/w15_img/main/$v${j// /}; b=/tmp/w15_img/branch/$v${j// /}
    n=0; same=0
    for f in $a/*.png; do n=$((n+1)); cmp -s $f $b/$(basename $f) && same=$((same+1)); done
    echo "$v ${j:-default}: $same of $n PNGs equal ($(ls $b/*.png | wc -l) in branch)"
  done
done
