#!/bin/sh
# Every PNG of 12-frame orbits of both octrees, at -j 1 and at the default thread count,
# from two source trees, compared byte for byte:
#   sh images_check.sh MAIN_TREE BRANCH_TREE MRI.vpk CT.vpk WORK_DIR
set -e
main=$1; branch=$2; mri=$3; ct=$4; work=$5
py=/work/venv/bin/python
for v in "$mri" "$ct"; do
  for j in 1 0; do
    for t in main branch; do
      eval tree=\$$t
      out="$work/$(basename "$v" .vpk)_j${j}_$t"
      rm -rf "$out"
      (cd "$work" && PYTHONPATH=$tree $py -m volpack walk "$v" "$out/" --orbit 12 -j $j --json > "$out.json")
    done
    a="$work/$(basename "$v" .vpk)_j${j}_main"; b="$work/$(basename "$v" .vpk)_j${j}_branch"
    n=0; same=0
    for f in "$a"/*.png; do
      n=$((n + 1))
      if cmp -s "$f" "$b/$(basename "$f")"; then same=$((same + 1)); fi
    done
    echo "$(basename "$v") -j $j: $same of $n PNGs equal (main vs branch)"
  done
done
