"""volpack's coders on white noise (no structure: the bound is the order-0 entropy),
64^3, seeded: the lossless codec on rint(sigma Z) + 30000 and on uniform integers 0..K-1,
and the lossy codec on uniform phase on [-pi, pi) at rel 1e-2..1e-4 (the outside of
phase_f32).

    PYTHONPATH=. python results/kinds39/white.py > results/kinds39/white.txt
"""

from __future__ import annotations

import numpy as np

import volpack.api as api
from volpack.volume_codec.lossless import LosslessCodec

rng = np.random.default_rng(39)
c = LosslessCodec()
for s in (3, 7, 35, 1100):
    q = (np.rint(rng.normal(scale=s, size=(64, 64, 64))) + 30000).astype(np.uint16)
    p = np.bincount(q.ravel()) / q.size
    h = -(p[p > 0] * np.log2(p[p > 0])).sum()
    b = 8 * len(c.encode(q)) / q.size
    print(f"lossless, Gaussian sigma {s}: H0 {h:.3f} bits, volpack {b:.3f} ({b / h:.4f}x)")
for k in (16, 500, 5000):
    q = rng.integers(0, k, size=(64, 64, 64)).astype(np.uint16)
    b = 8 * len(c.encode(q)) / q.size
    print(
        f"lossless, uniform on {k} values: H0 {np.log2(k):.3f} bits, volpack {b:.3f} ({b / np.log2(k):.4f}x)"
    )
u = rng.uniform(-np.pi, np.pi, size=(64, 64, 64)).astype(np.float32)
for rel in (1e-2, 1e-3, 1e-4):
    e = rel * 2 * np.pi
    h = np.log2(2 * np.pi / (2 * e))
    b = 8 * len(api.compress_array(u, max_error=e)) / u.size
    print(f"lossy, uniform phase at {rel:g}: bound {h:.3f} bits, volpack {b:.3f} ({b / h:.4f}x)")
