"""The long fitted predictor (bounded_longfit, version 2) at reaches the encoder does not
try (the decoder reads any reach 2..16 per axis): order-0 residual bits a voxel and the
static-context payload's bytes (head included).

python results/lossy/rough28/reaches.py FIELD.npy|name REL [REL ...]
"""

import sys

import numpy as np

sys.path.insert(0, "scripts")
sys.path.insert(0, "results/lossy/rough28")
from predictors import h0, load  # noqa: E402

from volpack.volume_codec import bounded_longfit as lf  # noqa: E402

REACHES = (
    (2, 2, 2),
    (2, 3, 3),
    (3, 3, 3),
    (2, 4, 4),
    (4, 4, 4),
    (2, 8, 8),
    (8, 8, 8),
    (12, 12, 12),
    (16, 16, 16),
)

if __name__ == "__main__":
    x = load(sys.argv[1]).astype(np.float64)
    lo, hi = x.min(), x.max()
    for rel in map(float, sys.argv[2:]):
        q = np.rint((x - lo) / (2 * rel * (hi - lo))).astype(np.int64)
        print(f"rel {rel:g}: tried by the encoder {lf.tried_reaches(q)}")
        for reach in REACHES:
            r, plan, w = lf.residuals(q, reach, prune=True)
            body = lf.code_static(r)
            n = None
            if body is not None:
                n = len(lf.encode_head(r, plan, w, code=lf.STATIC_CODED)[0] + body)
            print(f"   {reach}: {h0(r) / q.size:.4f} bits/voxel, static {n} B", flush=True)
