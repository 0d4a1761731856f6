"""The float CDF 9/7 wavelet (the irreversible filter of JPEG 2000 part 1) in 3-D.

Same layout as :mod:`volpack.wavelet.dwt3`: level ``k`` lifts the current low-pass region
along z, then y, then x (each axis only while it has levels left); a region of length
``n`` becomes low ``[0:ceil(n/2))`` and high ``[ceil(n/2):n)``. Boundaries use
whole-sample symmetric extension (``x[-1] = x[1]``, ``x[n] = x[n-2]``).

One 1-D level of even samples ``s`` and odd samples ``d`` (``formats/lossy-1.md``):

    d += A (s[i] + s[i+1]);  s += B (d[i-1] + d[i])
    d += G (s[i] + s[i+1]);  s += D (d[i-1] + d[i])
    s *= Z;  d /= Z

with the Daubechies-Sweldens factorisation constants below. The scaling makes the
transform nearly orthonormal (a coefficient's unit of error is a unit of voxel error in
the mean square), so one quantiser step serves every subband. The inverse runs the steps
backwards (``s /= Z``, ``d *= Z``, then subtract). Arithmetic is IEEE double in exactly
this order, no fused multiply-add (``volpack._jit.kernel`` keeps numba's strict math), so
an encoder and a decoder reconstruct the same bits.
"""

from __future__ import annotations

import numpy as np

from volpack._jit import kernel
from volpack.errors import FormatError

A = -1.586134342059924
B = -0.052980118572961
G = 0.882911075530934
D = 0.443506852043971
Z = 1.149604398860241


@kernel
def _lift_block(blk, s, d, backward):
    """One 1-D level along axis 0 of the 2-D view ``blk`` (n rows of w values), in place;
    ``s`` and ``d`` are scratch rows of at least ``ceil(n/2) * w`` values."""
    n, w = blk.shape
    ns = (n + 1) // 2
    nd = n // 2
    if backward:
        for i in range(ns):
            for j in range(w):
                s[i * w + j] = blk[i, j] / Z
        for i in range(nd):
            for j in range(w):
                d[i * w + j] = blk[ns + i, j] * Z
        _update(s, d, ns, nd, w, -D)
        _predict(s, d, ns, nd, w, -G)
        _update(s, d, ns, nd, w, -B)
        _predict(s, d, ns, nd, w, -A)
        for i in range(ns):
            for j in range(w):
                blk[2 * i, j] = s[i * w + j]
        for i in range(nd):
            for j in range(w):
                blk[2 * i + 1, j] = d[i * w + j]
        return
    for i in range(ns):
        for j in range(w):
            s[i * w + j] = blk[2 * i, j]
    for i in range(nd):
        for j in range(w):
            d[i * w + j] = blk[2 * i + 1, j]
    _predict(s, d, ns, nd, w, A)
    _update(s, d, ns, nd, w, B)
    _predict(s, d, ns, nd, w, G)
    _update(s, d, ns, nd, w, D)
    for i in range(ns):
        for j in range(w):
            blk[i, j] = s[i * w + j] * Z
    for i in range(nd):
        for j in range(w):
            blk[ns + i, j] = d[i * w + j] / Z


@kernel(inline=True)
def _predict(s, d, ns, nd, w, c):
    # d[i] += c (s[i] + s[i+1]); past the end s[i+1] mirrors to s[i] (x[n] = x[n-2]).
    for i in range(nd):
        r = i + 1 if i + 1 < ns else i
        for j in range(w):
            d[i * w + j] += c * (s[i * w + j] + s[r * w + j])


@kernel(inline=True)
def _update(s, d, ns, nd, w, c):
    # s[i] += c (d[i-1] + d[i]); d[-1] mirrors to d[0], d[nd] (odd n) to d[nd-1].
    for i in range(ns):
        left = i - 1 if i > 0 else 0
        right = i if i < nd else nd - 1
        for j in range(w):
            s[i * w + j] += c * (d[left * w + j] + d[right * w + j])


@kernel
def _lift_rows(plane, s, d, backward):
    """One 1-D level along the last axis of the 2-D view ``plane``, row by row, in place:
    the same arithmetic as :func:`_lift_block` on the transposed view, but every row is
    contiguous (the transposed view's rows stride across the volume)."""
    rows, n = plane.shape
    ns = (n + 1) // 2
    nd = n // 2
    for r in range(rows):
        row = plane[r]
        if backward:
            for i in range(ns):
                s[i] = row[i] / Z
            for i in range(nd):
                d[i] = row[ns + i] * Z
            _update(s, d, ns, nd, 1, -D)
            _predict(s, d, ns, nd, 1, -G)
            _update(s, d, ns, nd, 1, -B)
            _predict(s, d, ns, nd, 1, -A)
            for i in range(ns):
                row[2 * i] = s[i]
            for i in range(nd):
                row[2 * i + 1] = d[i]
        else:
            for i in range(ns):
                s[i] = row[2 * i]
            for i in range(nd):
                d[i] = row[2 * i + 1]
            _predict(s, d, ns, nd, 1, A)
            _update(s, d, ns, nd, 1, B)
            _predict(s, d, ns, nd, 1, G)
            _update(s, d, ns, nd, 1, D)
            for i in range(ns):
                row[i] = s[i] * Z
            for i in range(nd):
                row[ns + i] = d[i] / Z


@kernel
def _cdf97_kernel(a, regions, lz, ly, lx, s, d, backward):
    """The multilevel transform of ``a`` in place; ``regions[k]`` is the low-pass region
    that level ``k`` lifts."""
    top = regions.shape[0] - 1
    for i in range(top):
        k = top - 1 - i if backward else i
        cz, cy, cx = regions[k, 0], regions[k, 1], regions[k, 2]
        for step in range(3):
            axis = 2 - step if backward else step
            if axis == 0 and lz > k:
                for y in range(cy):
                    _lift_block(a[:cz, y, :cx], s, d, backward)
            elif axis == 1 and ly > k:
                for z in range(cz):
                    _lift_block(a[z, :cy, :cx], s, d, backward)
            elif axis == 2 and lx > k:
                for z in range(cz):
                    _lift_rows(a[z, :cy, :cx], s, d, backward)


def _run(x: np.ndarray, levels, backward: bool, overwrite: bool = False) -> np.ndarray:
    from volpack.wavelet import dwt3

    x = np.asarray(x)
    if x.ndim != 3:
        raise FormatError(f"expected a 3-D array, found {x.ndim} dimensions")
    full = dwt3.levels_for_shape(x.shape, None)
    lv = tuple(int(v) for v in levels)
    if len(lv) != 3 or any(not 0 <= v <= f for v, f in zip(lv, full)):
        raise FormatError(f"expected levels between (0, 0, 0) and {full}, found {levels!r}")
    out = np.array(x, dtype=np.float64, order="C", copy=not overwrite)
    if out.size and max(lv) > 0:
        # A block is n rows (along the lifted axis) of w <= max(ny, nx) values.
        width = max(out.shape[1], out.shape[2])
        rows = (max(out.shape) + 1) // 2
        s = np.empty(rows * width, np.float64)
        d = np.empty(rows * width, np.float64)
        regions = np.empty((max(lv) + 1, 3), np.int64)  # the low-pass region at each level
        regions[0] = out.shape
        for k in range(max(lv)):
            regions[k + 1] = [(n + 1) // 2 if v > k else n for n, v in zip(regions[k], lv)]
        _cdf97_kernel(out, regions, *lv, s, d, backward)
    return out


def forward(x: np.ndarray, levels: tuple[int, int, int]) -> np.ndarray:
    """CDF 9/7 coefficients (float64, Mallat layout) of a 3-D array; a new array."""
    return _run(x, levels, False)


def inverse(c: np.ndarray, levels: tuple[int, int, int], overwrite: bool = False) -> np.ndarray:
    """The voxels (float64) of coefficients made by :func:`forward`: a new array, or
    ``c`` itself transformed in place when ``overwrite`` and it is C-ordered float64."""
    return _run(c, levels, True, overwrite)
