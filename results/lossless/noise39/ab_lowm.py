"""LOWM on and off in one process (lossless.LOWM): bytes, bits/voxel, the round trip,
the bricks' payloads, and decode time of each stream (best of 3, the ratio).

    PYTHONPATH=. python results/lossless/noise39/ab_lowm.py F.npy ...
"""

from __future__ import annotations

import sys
import time

import numpy as np

from volpack.volume_codec import lossless
from volpack.volume_codec.lossless import LosslessCodec


def timed(f, k=3):
    best = None
    for _ in range(k):
        t = time.perf_counter()
        out = f()
        dt = time.perf_counter() - t
        best = dt if best is None else min(best, dt)
    return best, out


print(
    "| volume | shape dtype | bits/voxel LOWM off | on | change | decode time on/off | payload on |"
)
print("|---|---|---:|---:|---:|---:|---|")
for f in sys.argv[1:]:
    a = np.load(f)
    c = LosslessCodec()
    res = {}
    for on in (False, True):
        lossless.LOWM = on
        b = c.encode(a)
        dt, back = timed(lambda c=c, b=b, a=a: c.decode(b, a.shape, a.dtype))
        assert np.array_equal(back, a), f
        res[on] = (len(b), dt, lossless.describe(b))
    lossless.LOWM = True
    (n0, t0, _), (n1, t1, d1) = res[False], res[True]
    name = f.rsplit("/", 1)[-1].removesuffix(".npy")
    shape = "x".join(map(str, a.shape)) + " " + str(a.dtype)
    print(
        f"| {name} | {shape} | {8 * n0 / a.size:.4f} | {8 * n1 / a.size:.4f} | {n1 / n0 - 1:+.2%} | {t1 / t0:.3f} | {d1} |",
        flush=True,
    )
