"""Coefficient scans: the order in which a brick's wavelet coefficients are coded.

The coefficients of a 3-D Mallat decomposition form a forest. A detail coefficient at
level ``k`` (0 is the finest) at position ``p`` inside its subband has its parent at
``p // 2`` in the subband of the same orientation one level coarser; coefficients of the
coarsest level and of the approximation are roots. Two scans are offered:

``dfs``
    Roots coarse to fine, each tree in depth-first pre-order, so every subtree occupies a
    contiguous run of scan positions ``[i, end[i])``. A coder can then strip a subtree
    that holds only zeros with a single flag: the significance map is the set of
    subtrees that survive.
``line``
    Subband by subband, coarse to fine, each in raster order (no subtrees: ``end[i] ==
    i + 1``). Slightly worse ratios, but decoders write coefficients back in memory order.
``rows``
    The ``line`` order, where the first position of each row of a band (its run along
    x, when longer than one) roots the rest of that row: a coder strips a row of zeros
    with one flag. At loose bounds most rows of the fine bands are zero, and a decoder
    that skips them runs two to three times faster than on ``line``, for about the same
    size.

A scan also gives each position the scan position of its parent (coded earlier in both
orders; -1 for roots) and a subband class for context modelling. Scans depend only on
the brick shape and levels, so they are built once and cached.
"""

from __future__ import annotations

import functools

import numpy as np

from .._jit import kernel
from ..entropy.scan import Scan
from ..errors import OptionError
from .dwt3 import Band, subbands

ORDERS = ("dfs", "line", "rows")
# Subband classes: 4 per level for the 6 finest levels (by the count of high-pass axes)
# and one for the approximation; coarser levels share the sixth.
APPROX_CLASS = 24


def flat_index(shape, start, local):
    """Flat C-order indices of ``start + local`` (local: three broadcastable arrays)."""
    z, y, x = (s + loc for s, loc in zip(start, local))
    return (z * shape[1] + y) * shape[2] + x


def _band_class(band: Band, nlevels: int) -> int:
    if band.level == nlevels:
        return APPROX_CLASS
    return min(band.level, 5) * 4 + sum(band.bits)


@functools.lru_cache(maxsize=64)
def scan(shape: tuple[int, ...], levels: tuple[int, ...], order: str = "dfs") -> Scan:
    """Return the coding order of a brick of ``shape`` decomposed with ``levels``."""
    shape = tuple(int(s) for s in shape)
    levels = tuple(int(v) for v in levels)
    if order not in ORDERS:
        raise OptionError(f"expected order in {ORDERS}, found {order!r}")
    if len(shape) != 3 or len(levels) != 3 or min(shape) < 1:
        raise OptionError(f"expected a 3-D shape and 3 levels, found {shape} and {levels}")
    nlev = max(levels)
    bands = sorted(subbands(shape, levels), key=lambda b: b.level)  # finest first
    key = {(b.level, b.bits): b for b in bands}
    total = int(np.prod(shape))
    parent_flat = np.full(total, -1, dtype=np.int64)
    cls_flat = np.zeros(total, dtype=np.uint8)
    level_flat = np.zeros(total, dtype=np.int64)
    band_order = []  # (sort key, flat indices): coarse levels first, approximation first
    nbr_flat = np.full((total, 3), -1, dtype=np.int64)
    strides = (shape[1] * shape[2], shape[2], 1)
    for b in bands:
        local = np.ix_(*(np.arange(s) for s in b.size))
        idx = flat_index(shape, b.start, local).ravel()
        grid = np.indices(b.size).reshape(3, -1)
        for a in range(3):
            has = grid[a] > 0
            nbr_flat[idx[has], a] = idx[has] - strides[a]
        cls_flat[idx] = _band_class(b, nlev)
        level_flat[idx] = b.level
        band_order.append(((-b.level, b.bits), idx))
        pb = key.get((b.level + 1, b.bits)) if b.level < nlev else None
        if pb is None:
            continue
        active_next = [levels[a] > b.level + 1 for a in range(3)]
        ploc = []
        for a in range(3):
            p = np.arange(b.size[a])
            p = (
                np.minimum(p // 2, pb.size[a] - 1)
                if active_next[a]
                else np.minimum(p, pb.size[a] - 1)
            )
            ploc.append(p)
        pidx = flat_index(shape, pb.start, np.ix_(*ploc)).ravel()
        parent_flat[idx] = pidx
    band_order.sort(key=lambda t: t[0])
    line = np.concatenate([idx for _, idx in band_order])
    if order != "dfs":
        perm = line
        end = np.arange(1, total + 1, dtype=np.int64)
        if order == "rows":
            row_ends(end, [key[-lv, bits].size for (lv, bits), _ in band_order])
    else:
        perm, end = _dfs_order(parent_flat, line, level_flat)
    return scan_of(perm, end, parent_flat, cls_flat, nbr_flat)


def scan_of(perm, end, parent_flat, cls_flat, nbr_flat) -> Scan:
    """The read-only :class:`Scan` of a coding order ``perm`` (flat indices) whose
    parents, classes and neighbours are given per flat index (-1: none)."""
    total = perm.size
    pos = np.empty(total, dtype=np.int64)
    pos[perm] = np.arange(total, dtype=np.int64)
    pf = parent_flat[perm]
    parent = np.where(pf >= 0, pos[np.maximum(pf, 0)], -1)
    # 32-bit tables (bricks hold at most 2^30 voxels): half the memory traffic of int64.
    nf = nbr_flat[perm]
    nbr = np.where(nf >= 0, pos[np.maximum(nf, 0)], -1)
    out = Scan(
        perm.astype(np.int32),
        end.astype(np.int32),
        parent.astype(np.int32),
        cls_flat[perm],
        np.ascontiguousarray(nbr, dtype=np.int32),
    )
    for a in out:
        a.flags.writeable = False
    return out


def row_ends(end: np.ndarray, sizes) -> None:
    """Point the first position of each band row (longer than one) at the row's end."""
    start = 0
    for bz, by, bx in sizes:
        if bx > 1:
            firsts = start + bx * np.arange(bz * by)
            end[firsts] = firsts + bx
        start += bz * by * bx


def _dfs_order(parent: np.ndarray, roots_first: np.ndarray, level: np.ndarray):
    """Depth-first pre-order of the forest; ``roots_first`` orders roots and siblings."""
    n = parent.size
    rank = np.empty(n, dtype=np.int64)
    rank[roots_first] = np.arange(n)
    # Children lists (CSR), siblings in ``roots_first`` order.
    has_parent = parent >= 0
    kids = roots_first[has_parent[roots_first]]
    by_parent = kids[np.argsort(parent[kids], kind="stable")]
    counts = np.bincount(parent[has_parent], minlength=n)
    first = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(counts, out=first[1:])
    # Subtree sizes, accumulated from the finest level up.
    size = np.ones(n, dtype=np.int64)
    for lev in range(int(level.max(initial=0)) + 1):
        sel = np.nonzero((level == lev) & has_parent)[0]
        np.add.at(size, parent[sel], size[sel])
    roots = roots_first[~has_parent[roots_first]]
    perm = np.empty(n, dtype=np.int64)
    _dfs_kernel(roots, first, by_parent, perm)
    end = np.arange(n, dtype=np.int64) + size[perm]
    return perm, end


@kernel
def _dfs_kernel(roots, first, children, perm):
    # Explicit stack: children pushed last-first so the first child is visited first.
    stack = np.empty(perm.size + 1, dtype=np.int64)
    pos = 0
    for r in roots:
        top = 0
        stack[0] = r
        top = 1
        while top > 0:
            top -= 1
            node = stack[top]
            perm[pos] = node
            pos += 1
            for j in range(first[node + 1] - 1, first[node] - 1, -1):
                stack[top] = children[j]
                top += 1
