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
the brick shape and levels, so they are cached (within SCAN_CACHE_BYTES).
"""

from __future__ import annotations

import collections
import functools
import threading

import numpy as np

from .._jit import kernel
from ..entropy.scan import Scan
from ..errors import OptionError
from .dwt3 import Band, subbands

ORDERS = ("dfs", "line", "rows")
# Subband classes: 4 per level for the 6 finest levels (by the count of high-pass axes)
# and one for the approximation; coarser levels share the sixth.
APPROX_CLASS = 24


def _band_class(band: Band, nlevels: int) -> int:
    if band.level == nlevels:
        return APPROX_CLASS
    return min(band.level, 5) * 4 + sum(band.bits)


# What the scan caches of this module and of volpack.wavelet.packet hold at most,
# together (every scan takes 25 bytes a voxel): a few hundred of small bricks' scans, one
# of a 128^3 brick's. Session 30: an entry count (64 each) kept the six scans a 128^3
# float brick's lossy paths make, 290 MB, for the whole process; the paths now build
# again the few they need in turn (results/lossy/mem30).
SCAN_CACHE_BYTES = 64 << 20
SCAN_BYTES_A_VOXEL = 25
_held: collections.OrderedDict = collections.OrderedDict()  # (builder, args) -> scan
_lock = threading.Lock()  # the encoders' worker threads share it


def _held_bytes() -> int:
    return sum(a.nbytes for sc in _held.values() for a in sc)


def scan_cache(build):
    """Cache the scans ``build(shape, ...)`` returns (read-only, so shared; the arguments
    as given), the least recently used let go first to keep every cached scan within
    ``SCAN_CACHE_BYTES``: room is made before a scan is built, and the newest is kept
    whatever its size (a step search asks for the same scan again and again)."""
    name = f"{build.__module__}.{build.__qualname__}"

    @functools.wraps(build)
    def cached(shape, *args):
        key = (name, shape, *args)
        need = int(np.prod(shape)) * SCAN_BYTES_A_VOXEL
        with _lock:
            if key in _held:
                _held.move_to_end(key)
                return _held[key]
            total = _held_bytes()
            while _held and total + need > SCAN_CACHE_BYTES:
                total -= sum(a.nbytes for a in _held.popitem(last=False)[1])
        out = build(shape, *args)
        with _lock:
            _held[key] = out
            total = _held_bytes()
            while len(_held) > 1 and total > SCAN_CACHE_BYTES:
                total -= sum(a.nbytes for a in _held.popitem(last=False)[1])
        return out

    return cached


def clear_scans() -> None:
    """Let every cached scan go (this module's and volpack.wavelet.packet's)."""
    with _lock:
        _held.clear()


def scan(shape: tuple[int, ...], levels: tuple[int, ...], order: str = "dfs") -> Scan:
    """Return the coding order of a brick of ``shape`` decomposed with ``levels``."""
    shape = tuple(int(s) for s in shape)
    levels = tuple(int(v) for v in levels)
    if order not in ORDERS:
        raise OptionError(f"expected order in {ORDERS}, found {order!r}")
    if len(shape) != 3 or len(levels) != 3 or min(shape) < 1:
        raise OptionError(f"expected a 3-D shape and 3 levels, found {shape} and {levels}")
    if order == "rows":  # the line scan but for its row ends: its other tables shared
        return _rows(shape, levels, _scan(shape, levels, "line"))
    return _scan(shape, levels, order)


def _rows(shape, levels, line: Scan) -> Scan:
    end = np.arange(1, line.end.size + 1, dtype=np.int32)
    start = 0
    for b in sorted(subbands(shape, levels), key=lambda b: (-b.level, b.bits)):
        bz, by, bx = b.size
        if bx > 1:
            firsts = start + bx * np.arange(bz * by, dtype=np.int32)
            end[firsts] = firsts + bx
        start += bz * by * bx
    end.flags.writeable = False
    return line._replace(end=end)


@scan_cache
def _scan(shape: tuple[int, int, int], levels: tuple[int, int, int], order: str) -> Scan:
    """:func:`scan` of the ``dfs`` or ``line`` order (checked arguments)."""
    nlev = max(levels)
    bands = sorted(subbands(shape, levels), key=lambda b: (-b.level, b.bits))  # coding order
    at = {(b.level, b.bits): i for i, b in enumerate(bands)}
    # one row a band: start, size, class, the parent band (-1: its coefficients are
    # roots) and, per axis, whether a parent sits at half the position (split there)
    table = np.zeros((len(bands), 11), np.int64)
    for i, b in enumerate(bands):
        up = at.get((b.level + 1, b.bits), -1) if b.level < nlev else -1
        halves = [int(lv > b.level + 1) for lv in levels]
        table[i] = [*b.start, *b.size, _band_class(b, nlev), up, *halves]
    return scan_of_bands(shape, table, order == "dfs", False)


def scan_of_bands(shape: tuple[int, ...], table: np.ndarray, dfs: bool, rows: bool) -> Scan:
    """The read-only scan of the bands of ``table`` (int64, a row per band in coding
    order: start, size, class, parent band or -1, and per axis 1 where the parent sits
    at half the position), in the ``dfs`` order, else ``line`` (``rows``: the first
    position of each band row roots the row)."""
    total = int(np.prod(shape))
    out = Scan(np.empty(total, np.int32), np.empty(total, np.int32), np.empty(total, np.int32),
               np.empty(total, np.uint8), np.empty((total, 3), np.int32))  # fmt: skip
    _scan_kernel(shape[1], shape[2], table, dfs, rows, *out)
    for a in out:
        a.flags.writeable = False
    return out


@kernel
def _scan_kernel(ny, nx, bands, dfs, rows, perm, end, parent, cls, nbr):
    """:func:`scan` from its band table: flat indices band by band in coding order (the
    ``line`` order), each one's parent, class and in-band neighbours; for ``dfs`` the
    depth-first walk of that forest (siblings and roots in line order); then parents
    and neighbours as scan positions. One call where numpy took about a hundred a brick
    (2.3 ms a 32^3 brick, 30 shapes before a walk's first frame)."""
    # int32 work arrays as the tables (a brick holds at most 2^30 voxels): 45 bytes a
    # voxel beside the tables' 25, where int64 took 89 (200 MB for a 128^3 brick)
    n = perm.size
    line = np.empty(n, np.int32)
    up = np.full(n, -1, np.int32)  # parent's flat index
    near = np.full((n, 3), -1, np.int32)  # flat index of the z-1, y-1, x-1 neighbours
    kind = np.empty(n, np.uint8)
    q = 0
    for b in range(bands.shape[0]):
        z0, y0, x0, sz, sy, sx, c, pb = bands[b, 0], bands[b, 1], bands[b, 2], bands[b, 3], \
            bands[b, 4], bands[b, 5], bands[b, 6], bands[b, 7]  # fmt: skip
        for z in range(sz):
            for y in range(sy):
                for x in range(sx):
                    f = ((z0 + z) * ny + y0 + y) * nx + x0 + x
                    line[q] = f
                    q += 1
                    kind[f] = c
                    if z > 0:
                        near[f, 0] = f - ny * nx
                    if y > 0:
                        near[f, 1] = f - nx
                    if x > 0:
                        near[f, 2] = f - 1
                    if pb >= 0:
                        pz = min(z // 2 if bands[b, 8] else z, bands[pb, 3] - 1)
                        py = min(y // 2 if bands[b, 9] else y, bands[pb, 4] - 1)
                        px = min(x // 2 if bands[b, 10] else x, bands[pb, 5] - 1)
                        up[f] = (
                            ((bands[pb, 0] + pz) * ny + bands[pb, 1] + py) * nx + bands[pb, 2] + px
                        )
    if dfs:
        # children in line order (CSR), subtree sizes (a child comes after its parent in
        # line order, so backwards every size is complete before it is added), then the
        # walk with an explicit stack, the first child on top
        first = np.zeros(n + 1, np.int32)
        for f in range(n):
            if up[f] >= 0:
                first[up[f] + 1] += 1
        for f in range(n):
            first[f + 1] += first[f]
        fill = first[:n].copy()
        kids = np.empty(n, np.int32)
        size = np.ones(n, np.int32)
        for i in range(n):
            f = line[i]
            if up[f] >= 0:
                kids[fill[up[f]]] = f
                fill[up[f]] += 1
        for i in range(n - 1, -1, -1):
            f = line[i]
            if up[f] >= 0:
                size[up[f]] += size[f]
        stack = np.empty(n + 1, np.int32)
        pos = 0
        for i in range(n):
            if up[line[i]] >= 0:
                continue
            stack[0] = line[i]
            top = 1
            while top > 0:
                top -= 1
                f = stack[top]
                perm[pos] = f
                end[pos] = pos + size[f]
                pos += 1
                for j in range(first[f + 1] - 1, first[f] - 1, -1):
                    stack[top] = kids[j]
                    top += 1
    else:
        for i in range(n):
            perm[i] = line[i]
            end[i] = i + 1
        if rows:  # the first position of each band row (longer than one) ends the row
            start = 0
            for b in range(bands.shape[0]):
                sx = bands[b, 5]
                count = bands[b, 3] * bands[b, 4]
                if sx > 1:
                    for r in range(count):
                        end[start + sx * r] = start + sx * r + sx
                start += count * sx
    at = np.empty(n, np.int32)
    for i in range(n):
        at[perm[i]] = i
    for i in range(n):
        f = perm[i]
        parent[i] = at[up[f]] if up[f] >= 0 else -1
        cls[i] = kind[f]
        for a in range(3):
            nbr[i, a] = at[near[f, a]] if near[f, a] >= 0 else -1
