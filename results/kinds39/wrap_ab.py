"""What unwrapping would give on the wrapped MRI phase (phase_f32), measured on the
quantised voxels the lossy path codes, by the lossless codec (the same predictive coder
the quantised bricks take):

    PYTHONPATH=. python results/kinds39/wrap_ab.py DATA_DIR > results/kinds39/wrap_ab.txt

For E = rel x range, q = rint((x - lo) / 2E) has a period of K = 2 pi / 2E bins (not an
integer: the unwrapped u = q + k K is rounded, so u mod K is not q exactly; this measures
size only). Three versions of q: as it is (wrapped); unwrapped along x within each row
where the steps are coherent (|step| < K / 4 after removing multiples of K; reset to 0
wraps at an incoherent step: any choice of k per voxel would decode, the decoder takes u
back modulo K); and the oracle, made from the field before it was wrapped (make.py's
generator) inside the head.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make  # noqa: E402

from volpack.volume_codec.lossless import LosslessCodec  # noqa: E402

D = Path(sys.argv[1])
a = np.load(D / "phase_f32.npy").astype(np.float64)
z, y, x = make.grid(a.shape, -1.0, 1.0)
head = (z / 0.85) ** 2 + (y / 0.9) ** 2 + (x / 0.75) ** 2 < 1
rng = np.random.default_rng(3900 + list(make.MAKERS).index("phase_f32"))
dz, dy, dx = z + 0.2, y - 0.45, x
r2 = dz**2 + dy**2 + dx**2 + 0.01
dip = (3 * dz**2 / r2 - 1) / r2**1.5 * 0.012
b0 = (
    4 * z
    + 3 * y * x
    - 5 * x**2
    + 2.5 * z * y
    + dip * 40
    + 0.6 * make.gauss_field(rng, a.shape, -5.0)
)
ph = 2.5 * b0 + rng.normal(scale=0.05, size=a.shape)
oracle = np.where(head, ph, a)


def coherent_unwrap(q, K):
    d = np.diff(q, axis=2).astype(np.float64)
    w = np.rint(d / K)
    jump = np.where(np.abs(d - w * K) < K / 4, -w, 0.0)
    k = np.concatenate([np.zeros(q.shape[:2] + (1,)), np.cumsum(jump, axis=2)], axis=2)
    return np.rint(q + k * K).astype(np.int64)


codec = LosslessCodec()
lo = a.min()
for rel in (1e-2, 1e-3, 1e-4):
    E = rel * (a.max() - a.min())
    K = 2 * np.pi / (2 * E)
    q = np.rint((a - lo) / (2 * E)).astype(np.int64)
    u = coherent_unwrap(q, K)
    o = np.rint((oracle - lo) / (2 * E)).astype(np.int64)
    sizes = {}
    for name, v in (("wrapped", q), ("unwrapped along x", u), ("oracle", o)):
        v = v - v.min()
        dt = np.uint16 if v.max() < 65536 else np.uint32
        sizes[name] = len(codec.encode(v.astype(dt)))
    base = sizes["wrapped"]
    print(
        f"rel {rel:g}: K = {K:.1f} bins; "
        + "; ".join(f"{k} {s:,} B ({base / s:.4f}x fewer)" for k, s in sizes.items())
    )
