"""Special voxels: NaN, +Inf, -Inf and a declared fill value.

Lossy coders keep them out of their transforms and predictions and restore them bit for
bit: the bounded brick codec (:mod:`.lossy`) and the animation frames
(:mod:`volpack.animation.specials`) find them here and put a neutral value in their
place before coding.
"""

from __future__ import annotations

import numpy as np


def special_voxels(x: np.ndarray, fill: float | None) -> np.ndarray:
    """Boolean array: the voxels of ``x`` that are NaN, +-Inf or equal to ``fill``."""
    m = ~np.isfinite(x) if x.dtype.kind == "f" else np.zeros(x.shape, bool)
    if fill is not None:
        m |= x == fill
    return m


def special_mask(x: np.ndarray, fill: float | None) -> np.ndarray | None:
    """:func:`special_voxels`, or None when there are none (or cannot be: integer voxels
    without a fill value)."""
    if x.dtype.kind != "f" and fill is None:
        return None
    m = special_voxels(x, fill)
    return m if m.any() else None


def fill_masked(a: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Copy of ``a`` whose masked voxels take the last valid value before them (C order;
    those before the first valid voxel take its value; all masked: zeros)."""
    flat = a.reshape(-1)
    m = mask.reshape(-1)
    out = flat.copy()
    if m.all():
        out[:] = 0
        return out.reshape(a.shape)
    idx = np.where(~m, np.arange(flat.size), 0)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(~m))
    idx[:first] = first
    out = flat[idx]
    return out.reshape(a.shape)
