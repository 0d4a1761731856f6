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


# A missing-value sentinel (-9999, 1e20, ...) not declared as the fill value: the
# brick's smallest or largest valid value, held by at least this share of its voxels and
# apart from the others by more than 1/16 of their spread.
SENTINEL_SHARE = 1e-3


def sentinel(x: np.ndarray, mask: np.ndarray | None) -> float | None:
    """A value of the float brick ``x`` (``mask``: voxels already special) that looks like
    an undeclared fill value, else None. The bounded codec also codes the brick with it
    masked (stored exactly) and keeps the shorter: where it marks a region (land, ground
    under a storm) its cliff at every edge of that region costs the predictions and
    transforms far more than the mask."""
    v = x.reshape(-1) if mask is None else x.reshape(-1)[~mask.reshape(-1)]
    if v.size < 64:
        return None
    lo, hi = v.min(), v.max()
    at_lo, at_hi = v == lo, v == hi
    rest = v[~(at_lo | at_hi)]
    if rest.size == 0:
        return None
    a, b = float(rest.min()), float(rest.max())
    need = max(16, SENTINEL_SHARE * x.size)
    gap = (b - a) / 16
    n_lo, n_hi = int(at_lo.sum()), int(at_hi.sum())
    if n_lo >= need and a - float(lo) > gap and n_lo >= n_hi:
        return float(lo)
    if n_hi >= need and float(hi) - b > gap:
        return float(hi)
    if n_lo >= need and a - float(lo) > gap:
        return float(lo)
    return None
