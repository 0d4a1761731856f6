"""The predictor's share of the excess: volpack's fitted predictor (16 causal neighbours,
predictfit.FIT_OFFSETS, least squares, no constant term) against the same fit with a
constant term, one class each, on a central crop (at most 48x96x96) of each volume:
the order-0 entropy of each rounded prediction's residual, and of the values (the bound
for white noise, where the best predictor is the constant mean).

    PYTHONPATH=. python results/lossless/noise39/intercept.py F.npy ...
"""

from __future__ import annotations

import sys

import numpy as np

from volpack.volume_codec.predictfit import FIT_OFFSETS


def h0(a):
    _, c = np.unique(a, return_counts=True)
    p = c / c.sum()
    return float(-(p * np.log2(p)).sum())


def crop(a, s=(48, 96, 96)):
    sl = tuple(slice(max((n - m) // 2, 0), max((n - m) // 2, 0) + m) for n, m in zip(a.shape, s))
    return a[sl]


print("| volume | crop | H0 values | fit, no constant (volpack) | fit with a constant | gain |")
print("|---|---|---:|---:|---:|---:|")
for f in sys.argv[1:]:
    v = crop(np.load(f)).astype(np.float64)
    nz, ny, nx = v.shape
    t = v[2:, 2:-1, 2:-1]
    cols = [
        v[2 - dz : nz - dz, 2 - dy : ny - 1 - dy, 2 - dx : nx - 1 - dx].ravel()
        for dz, dy, dx in FIT_OFFSETS
    ]
    X = np.stack(cols, 1)
    y = t.ravel()
    out = []
    for A in (X, np.hstack([X, np.ones((X.shape[0], 1))])):
        w, *_ = np.linalg.lstsq(A, y, rcond=None)
        out.append(h0(y - np.rint(A @ w)))
    name = f.rsplit("/", 1)[-1].removesuffix(".npy")
    print(
        f"| {name} | {'x'.join(map(str, v.shape))} | {h0(y):.3f} | {out[0]:.3f} | {out[1]:.3f} | {out[1] - out[0]:+.3f} |"
    )
