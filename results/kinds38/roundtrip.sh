#!/bin/sh
# A user's round trip on a few of the trial's volumes: compress, info, decompress, check.
#   sh results/kinds38/roundtrip.sh DIR OUTDIR NAME[:REL] ...
# (run from the worktree with PYTHONPATH set; REL: a --rel-error for a float field)
D=$1; O=$2; shift 2
mkdir -p "$O"
PY=/work/venv/bin/python
for spec in "$@"; do
  n=${spec%%:*}; rel=${spec#*:}; [ "$rel" = "$spec" ] && rel=""
  tag=$n${rel:+_$rel}
  if [ -n "$rel" ]; then opt="--rel-error $rel"; else opt=""; fi
  echo "== $tag"
  $PY -m volpack -q compress "$D/$n.npy" "$O/$tag.vpk" $opt || echo "compress FAILED rc=$?"
  $PY -m volpack info "$O/$tag.vpk" | head -20 || echo "info FAILED rc=$?"
  $PY -m volpack -q decompress "$O/$tag.vpk" "$O/$tag.out.npy" || echo "decompress FAILED rc=$?"
  $PY - "$D/$n.npy" "$O/$tag.out.npy" "$rel" <<'PYEOF'
import sys, numpy as np
a, b, rel = np.load(sys.argv[1]), np.load(sys.argv[2]), sys.argv[3]
assert a.shape == b.shape and a.dtype == b.dtype, (a.shape, b.shape, a.dtype, b.dtype)
if not rel:
    print("exact:", bool(np.array_equal(a.view(np.uint8), b.view(np.uint8))))
else:
    f = np.isfinite(a)
    e = float(rel) * float(a[f].max() - a[f].min())
    err = np.abs(a.astype(np.float64) - b.astype(np.float64))[f].max()
    print(f"max error / bound over the finite range: {err / e:.6f}", "held" if err <= e else "BROKEN")
PYEOF
  rm -f "$O/$tag.out.npy"
done
