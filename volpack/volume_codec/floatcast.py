"""A float64 reconstruction clipped to float32's finite range and cast, in one pass.

The lossy decoders rebuild voxels in double precision and hand back the volume's dtype.
``np.clip`` then ``astype`` walk the array twice and allocate twice; this kernel does
both in one walk with the same results: values past ``+-big`` become ``+-big``, NaN
stays NaN (as ``np.clip`` leaves it) and the cast rounds to nearest like numpy's.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel

_U = np.uint64


@kernel(nrt=False)
def _clip_cast(v, out, big):
    for i in range(v.size):
        x = v[_U(i)]
        if x > big:
            x = big
        elif x < -big:
            x = -big
        out[_U(i)] = x


def to_float32(v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``np.clip(v, -big, big).astype(np.float32)`` for a C-contiguous float64 ``v``
    (``big`` the largest finite float32), written into ``out`` (C-contiguous float32 of
    ``v``'s size) when given."""
    if out is None:
        out = np.empty(v.shape, np.float32)
    _clip_cast(v.reshape(-1), out.reshape(-1), float(np.finfo(np.float32).max))
    return out
