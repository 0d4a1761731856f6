"""What fibsem_u8's curtaining stripes and slice drift cost volpack's lossless coder: the
volume made again (the same seed) without each part, coded in one process.

    PYTHONPATH=. python results/kinds39/fibsem_parts.py > results/kinds39/fibsem_parts.txt
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make  # noqa: E402

import volpack.api as api  # noqa: E402


def fibsem(stripes_on=True, drift_on=True, noise=7.0):
    """make.fibsem_u8 with parts switched off (the same draws, so the rest is the same)."""
    rng = np.random.default_rng(3900 + list(make.MAKERS).index("fibsem_u8"))
    shape = (96, 160, 160)
    d1, d2, _ = make.voronoi(rng, shape, 900)
    mem = np.exp(-(((d2 - d1) / 1.3) ** 2))
    tex = make.gauss_field(rng, shape, -2.0)
    v = 150 + 12 * tex - 85 * mem
    ves = make.gauss_field(rng, shape, -5.0)
    v -= 40 * (ves > 2.2)
    stripes = np.cumsum(rng.normal(size=(shape[0], shape[2])), axis=0) * 0.4
    stripes = ndimage.gaussian_filter1d(stripes, 0.8, axis=1) + rng.normal(size=shape[2]) * 6
    v += stripes[:, None, :] * stripes_on
    v += np.cumsum(rng.normal(scale=1.0, size=shape[0]))[:, None, None] * drift_on
    v = ndimage.gaussian_filter(v, 0.6) + rng.normal(scale=1.0, size=shape) * noise
    return make.q(v, np.uint8)


base = fibsem()
assert np.array_equal(base, np.load(sys.argv[1] + "/fibsem_u8.npy")) if len(sys.argv) > 1 else True
ref = len(api.compress_array(base))
print(f"fibsem_u8 as made: {ref:,} B")
for name, kw in (("no curtaining stripes", dict(stripes_on=False)), ("no slice drift", dict(drift_on=False)),
                 ("neither", dict(stripes_on=False, drift_on=False)), ("no noise (sigma 0)", dict(noise=0.0))):  # fmt: skip
    n = len(api.compress_array(fibsem(**kw)))
    print(f"  {name}: {n:,} B ({ref / n:.4f}x fewer than as made)")
