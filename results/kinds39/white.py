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

# Where the Gaussian case's overhead could come from: the order-0 entropy of the residual
# of an ideal causal predictor of white noise, the rounded mean of its m causal
# neighbours (3: the face neighbours; 13: the causal half of the 3x3x3 cube), against
# the coder's bits above.
for s in (7, 1100):
    q = np.rint(rng.normal(scale=s, size=(64, 64, 64))).astype(np.int64) + 30000
    p = np.bincount(q.ravel() - q.min()) / q.size
    h = -(p[p > 0] * np.log2(p[p > 0])).sum()
    b = 8 * len(c.encode(q.astype(np.uint16))) / q.size
    cube = [(dz, dy, dx) for dz in (-1, 0, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)]
    causal = [o for o in cube if o < (0, 0, 0)]  # lexicographically before the voxel
    for name, offs in (("3 face", [(-1, 0, 0), (0, -1, 0), (0, 0, -1)]), ("13 causal", causal)):
        inner = q[1:-1, 1:-1, 1:-1]
        acc = sum(np.roll(q, (-dz, -dy, -dx), (0, 1, 2))[1:-1, 1:-1, 1:-1] for dz, dy, dx in offs)
        r = inner - np.rint(acc / len(offs)).astype(np.int64)
        pr = np.bincount(r.ravel() - r.min()) / r.size
        hr = -(pr[pr > 0] * np.log2(pr[pr > 0])).sum()
        print(f"Gaussian sigma {s}: H0 {h:.3f}; mean of {name} neighbours' residual {hr:.3f} bits "
              f"(+{hr - h:.3f}); volpack {b:.3f} (+{b - h:.3f})")  # fmt: skip
