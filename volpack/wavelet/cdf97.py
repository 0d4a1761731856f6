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
def _lift_block(blk, s, d):
    """One forward 1-D level along axis 0 of the 2-D view ``blk`` (n rows of w values),
    in place; ``s`` and ``d`` are scratch rows of at least ``ceil(n/2) * w`` values."""
    n, w = blk.shape
    ns = (n + 1) // 2
    nd = n // 2
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
def _lift_rows(plane, s, d):
    """One forward 1-D level along the last axis of the 2-D view ``plane``, row by row,
    in place: the same arithmetic as :func:`_lift_block` on the transposed view, but
    every row is contiguous (the transposed view's rows stride across the volume)."""
    rows, n = plane.shape
    ns = (n + 1) // 2
    nd = n // 2
    for r in range(rows):
        row = plane[r]
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
def _forward_kernel(a, regions, lz, ly, lx, s, d):
    """The multilevel forward transform of ``a`` in place; ``regions[k]`` is the
    low-pass region that level ``k`` lifts."""
    for k in range(regions.shape[0] - 1):
        cz, cy, cx = regions[k, 0], regions[k, 1], regions[k, 2]
        if lz > k:
            for y in range(cy):
                _lift_block(a[:cz, y, :cx], s, d)
        if ly > k:
            for z in range(cz):
                _lift_block(a[z, :cy, :cx], s, d)
        if lx > k:
            for z in range(cz):
                _lift_rows(a[z, :cy, :cx], s, d)


# The inverse, which every decoder runs (the encoder too, to rebuild what the decoder
# will see). The arithmetic is the forward's steps undone in the order of
# formats/lossy-1.md, each value computed by the same IEEE operations as a pass-by-pass
# inverse would; only the loop order differs. Flat arrays with unsigned indices (numba
# tests signed ones for a negative wrap-around, which stops LLVM's vectoriser), and
# along z and y the four lifting steps fused into one sweep over the rows of a plane
# (a step on row i needs only rows i - 1 .. i + 1 of the step before), so each row is
# loaded, lifted and stored once instead of seven times.

_U = np.uint64


@kernel(inline=True)
def _lift_vec(x, xo, y, lo, ro, w, c):
    """``x[xo + j] += c * (y[lo + j] + y[ro + j])`` for ``j < w``."""
    for j in range(w):
        x[_U(xo + j)] += c * (y[_U(lo + j)] + y[_U(ro + j)])


@kernel(inline=True)
def _unlift_s_row(s, d, i, ns, nd, w, c):
    """Row ``i`` (if there is one) of ``s[i] += c (d[i-1] + d[i])``, ends mirrored."""
    if 0 <= i < ns:
        left = i - 1 if i > 0 else 0
        right = i if i < nd else nd - 1
        _lift_vec(s, i * w, d, left * w, right * w, w, c)


@kernel(inline=True)
def _unlift_d_row(d, s, i, ns, nd, w, c):
    """Row ``i`` (if there is one) of ``d[i] += c (s[i] + s[i+1])``, the end mirrored."""
    if 0 <= i < nd:
        r = i + 1 if i + 1 < ns else i
        _lift_vec(d, i * w, s, i * w, r * w, w, c)


@kernel(inline=True)
def _unlift_rows_of(flat, base, stride, s, d, ns, nd, w):
    """One inverse level along an axis whose samples are rows of ``w`` values
    ``stride`` apart from ``flat[base]``: low rows ``[0, ns)``, high ``[ns, ns + nd)``.
    ``s`` and ``d`` are scratch of ``ns * w`` and ``nd * w`` values."""
    for i in range(ns):
        o = base + i * stride
        for j in range(w):
            s[_U(i * w + j)] = flat[_U(o + j)] / Z
    for i in range(nd):
        o = base + (ns + i) * stride
        for j in range(w):
            d[_U(i * w + j)] = flat[_U(o + j)] * Z
    # Sweep t: step 1 (s, -D) on row t, step 2 (d, -G) on t - 1, step 3 (s, -B) on
    # t - 2, step 4 (d, -A) on t - 3, whose two output rows are then final.
    for t in range(ns + 3):
        _unlift_s_row(s, d, t, ns, nd, w, -D)
        _unlift_d_row(d, s, t - 1, ns, nd, w, -G)
        _unlift_s_row(s, d, t - 2, ns, nd, w, -B)
        i = t - 3
        if 0 <= i < nd:
            _unlift_d_row(d, s, i, ns, nd, w, -A)
            o = base + (2 * i + 1) * stride
            for j in range(w):
                flat[_U(o + j)] = d[_U(i * w + j)]
        if 0 <= i < ns:
            o = base + 2 * i * stride
            for j in range(w):
                flat[_U(o + j)] = s[_U(i * w + j)]


@kernel(inline=True)
def _unlift_s(s, d, ns, nd, c):
    """``s[i] += c (d[i-1] + d[i])`` with the mirrored ends, the loop free of tests."""
    s[_U(0)] += c * (d[_U(0)] + d[_U(0)])
    for i in range(1, nd):
        s[_U(i)] += c * (d[_U(i - 1)] + d[_U(i)])
    if ns > nd:
        s[_U(nd)] += c * (d[_U(nd - 1)] + d[_U(nd - 1)])


@kernel(inline=True)
def _unlift_d(d, s, ns, nd, c):
    """``d[i] += c (s[i] + s[i+1])`` with the mirrored end."""
    m = nd if ns > nd else nd - 1
    for i in range(m):
        d[_U(i)] += c * (s[_U(i)] + s[_U(i + 1)])
    if m < nd:
        d[_U(m)] += c * (s[_U(m)] + s[_U(m)])


@kernel(inline=True)
def _unlift_row(flat, o, s, d, n):
    """One inverse level of the contiguous run ``flat[o:o+n]`` (``n >= 2``), in place."""
    ns = (n + 1) // 2
    nd = n // 2
    for i in range(ns):
        s[_U(i)] = flat[_U(o + i)] / Z
    for i in range(nd):
        d[_U(i)] = flat[_U(o + ns + i)] * Z
    _unlift_s(s, d, ns, nd, -D)
    _unlift_d(d, s, ns, nd, -G)
    _unlift_s(s, d, ns, nd, -B)
    _unlift_d(d, s, ns, nd, -A)
    for i in range(nd):
        flat[_U(o + 2 * i)] = s[_U(i)]
        flat[_U(o + 2 * i + 1)] = d[_U(i)]
    if ns > nd:
        flat[_U(o + 2 * nd)] = s[_U(nd)]


@kernel(nrt=False)
def _inverse_kernel(flat, ny, nx, regions, lz, ly, lx, s, d):
    """The multilevel inverse of the C-ordered array ``flat`` (``ny * nx`` per slice) in
    place: coarsest level first, along x, then y, then z."""
    top = regions.shape[0] - 1
    for i in range(top):
        k = top - 1 - i
        cz, cy, cx = regions[k, 0], regions[k, 1], regions[k, 2]
        if lx > k:
            for z in range(cz):
                for y in range(cy):
                    _unlift_row(flat, (z * ny + y) * nx, s, d, cx)
        if ly > k:
            for z in range(cz):
                _unlift_rows_of(flat, z * ny * nx, nx, s, d, (cy + 1) // 2, cy // 2, cx)
        if lz > k:
            for y in range(cy):
                _unlift_rows_of(flat, y * nx, ny * nx, s, d, (cz + 1) // 2, cz // 2, cx)


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
        if backward:
            _inverse_kernel(out.reshape(-1), out.shape[1], out.shape[2], regions, *lv, s, d)
        else:
            _forward_kernel(out, regions, *lv, s, d)
    return out


def forward(x: np.ndarray, levels: tuple[int, int, int]) -> np.ndarray:
    """CDF 9/7 coefficients (float64, Mallat layout) of a 3-D array; a new array."""
    return _run(x, levels, False)


def inverse(c: np.ndarray, levels: tuple[int, int, int], overwrite: bool = False) -> np.ndarray:
    """The voxels (float64) of coefficients made by :func:`forward`: a new array, or
    ``c`` itself transformed in place when ``overwrite`` and it is C-ordered float64."""
    return _run(c, levels, True, overwrite)
