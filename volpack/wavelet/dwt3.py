"""Reversible integer 3-D wavelet transform in the Mallat layout.

The transform is separable and non-standard: level ``k`` lifts the current low-pass
region ``[0:nz_k, 0:ny_k, 0:nx_k)`` along z, then y, then x (each axis only while it has
levels left), and the next level works on the low-low-low corner that results. Along an
axis, a region of length ``n`` becomes low ``[0:ceil(n/2))`` and high ``[ceil(n/2):n)``.

Wavelets (see :mod:`volpack.wavelet.lifting` for the lifting tables and boundaries):

``"53"``
    reversible CDF 5/3 (LeGall, JPEG 2000 part 1), whole-sample symmetric extension.
``"97m"``
    reversible 9/7-M (JPEG 2000 part 2), whole-sample symmetric extension.
``"haar"``
    integer S-transform, half-sample symmetric extension.
``"26"``
    reversible 2/6 (TS) transform of Calderbank, Daubechies, Sweldens and Yeo:
    S-transform then ``d += floor((s[k-1] - s[k+1] + 2) / 4)``, half-sample symmetric.

All four keep a constant signal's details at zero and its low-pass value unchanged.
"""

from __future__ import annotations

import functools
import math
from fractions import Fraction
from typing import NamedTuple

import numpy as np

from volpack._jit import kernel
from volpack.errors import FormatError
from volpack.wavelet.lifting import SPECS, lift_planes_kernel, lift_rows_kernel

WAVELETS = tuple(SPECS)
WORK_DTYPES = (np.dtype(np.int32), np.dtype(np.int64))
_I32 = np.iinfo(np.int32)
# int64 registers hold at most 20 * |stored value| + 8 (the 9/7-M prediction sum).
_I64_SAFE = (1 << 63) // 32


def _check_wavelet(wavelet: str) -> np.ndarray:
    try:
        return SPECS[wavelet]
    except (KeyError, TypeError):
        raise FormatError(f"expected a wavelet in {WAVELETS}, found {wavelet!r}") from None


def levels_for_shape(shape: tuple[int, int, int], max_levels: int | None) -> tuple[int, int, int]:
    """Number of decomposition levels along each axis.

    An axis is split while its current low-pass length is at least 2, so a length-``n``
    axis gets ``ceil(log2(n))`` levels (1 -> 0, 2 -> 1, 3 -> 2, 64 -> 6, 65 -> 7), capped
    by ``max_levels`` (``None``: no cap). The last levels act on 2 or 3 samples; they cost
    almost nothing and still decorrelate the few remaining low-pass values. The rule is
    the same for every wavelet.
    """
    if len(shape) != 3:
        raise FormatError(f"expected a 3-D shape, found {tuple(shape)}")
    if max_levels is not None and int(max_levels) < 0:
        raise FormatError(f"expected max_levels >= 0 or None, found {max_levels!r}")
    out = []
    for n in shape:
        n = int(n)
        if n < 0:
            raise FormatError(f"expected non-negative axis lengths, found shape {tuple(shape)}")
        k = 0
        while n >= 2 and (max_levels is None or k < int(max_levels)):
            n = (n + 1) // 2
            k += 1
        out.append(k)
    return tuple(out)  # type: ignore[return-value]


def _check_levels(shape: tuple[int, ...], levels) -> tuple[int, int, int]:
    try:
        lv = tuple(int(v) for v in levels)
    except TypeError:
        raise FormatError(f"expected three level counts, found {levels!r}") from None
    full = levels_for_shape(shape, None)
    if len(lv) != 3 or any(v < 0 or v > f for v, f in zip(lv, full)):
        raise FormatError(
            f"expected levels between (0, 0, 0) and {full} for shape {tuple(shape)}, found {levels!r}"
        )
    return lv  # type: ignore[return-value]


def _region_lengths(shape, levels) -> list[tuple[int, int, int]]:
    """Current low-pass region at the start of each level (and after the last one)."""
    cur = [int(n) for n in shape]
    out = [tuple(cur)]
    for k in range(max(levels, default=0)):
        cur = [(n + 1) // 2 if lv > k else n for n, lv in zip(cur, levels)]
        out.append(tuple(cur))
    return out  # type: ignore[return-value]


class Band(NamedTuple):
    """One subband of the Mallat layout."""

    level: int  # 0 finest; the approximation has level == max(levels)
    bits: tuple[int, int, int]  # 1 = high-pass along z/y/x
    start: tuple[int, int, int]
    size: tuple[int, int, int]

    @property
    def slices(self) -> tuple[slice, slice, slice]:
        return tuple(slice(s, s + n) for s, n in zip(self.start, self.size))


def subbands(shape: tuple[int, int, int], levels) -> list[Band]:
    """Every non-empty subband of the Mallat layout, coarsest first.

    The approximation (labelled ``level = max(levels)``, bits ``(0, 0, 0)``) comes first,
    then the details of levels ``max(levels) - 1`` down to 0 (level 0 is the finest,
    computed first). Bits are 1 for high-pass along z/y/x, only on axes active at that
    level; a level's bands come in increasing bit order (``(0, 0, 1)``, ``(0, 1, 0)``,
    ...). The bands tile the whole array exactly once.
    """
    shape = tuple(int(n) for n in shape)
    levels = _check_levels(shape, levels)
    regions = _region_lengths(shape, levels)
    top = max(levels)
    out = [Band(top, (0, 0, 0), (0, 0, 0), tuple(regions[top]))]
    for k in range(top - 1, -1, -1):
        cur = regions[k]
        active = [lv > k for lv in levels]
        for bits in np.ndindex(*(2 if a else 1 for a in active)):
            if not any(bits):
                continue
            start, size = [], []
            for n, b, a in zip(cur, bits, active):
                h = (n + 1) // 2 if a else n
                start.append(h if b else 0)
                size.append(n - h if b else h)
            if min(size) > 0:
                out.append(Band(k, tuple(int(b) for b in bits), tuple(start), tuple(size)))
    return out


@functools.lru_cache(maxsize=32)
def band_scale(shape: tuple[int, int, int], levels: tuple[int, int, int]) -> np.ndarray:
    """Per-coefficient factor from the integer lifting's units to orthonormal units.

    Each low-pass step of the reversible filters keeps the mean (orthonormal: times
    sqrt 2), each high-pass step keeps a difference (orthonormal: divided by sqrt 2), so a
    subband reached by ``l`` low and ``h`` high steps over the three axes scales by
    ``2 ** ((l - h) / 2)``. (Here, not with the codec that uses it most, so that an
    octree reader does not import the codecs.)
    """
    out = np.empty(shape, np.float64)
    for b in subbands(shape, levels):
        ex = 0
        for a in range(3):
            if b.level < levels[a]:  # this axis was split at the band's level
                ex += b.level + (0 if b.bits[a] else 1) - b.bits[a]
            else:
                ex += levels[a]
        out[b.slices] = 2.0 ** (ex / 2)
    out = out.reshape(-1)
    out.flags.writeable = False
    return out


@kernel
def dwt3_kernel(a, tmp, lz, ly, lx, spec, backward):
    """Forward (or, with ``backward``, inverse) multilevel transform of ``a`` in place."""
    nz, ny, nx = a.shape
    top = max(lz, max(ly, lx))
    rz = np.empty(top + 1, np.int64)
    ry = np.empty(top + 1, np.int64)
    rx = np.empty(top + 1, np.int64)
    rz[0], ry[0], rx[0] = nz, ny, nx
    for k in range(top):
        rz[k + 1] = (rz[k] + 1) // 2 if lz > k else rz[k]
        ry[k + 1] = (ry[k] + 1) // 2 if ly > k else ry[k]
        rx[k + 1] = (rx[k] + 1) // 2 if lx > k else rx[k]
    az = a.reshape((1, nz, ny, nx))
    ay = a.reshape((nz, ny, 1, nx))
    # Runtime (non-literal) arguments only, so that each callee compiles once per dtype.
    one = np.int64(nz > 0)
    for i in range(top):
        k = top - 1 - i if backward else i
        cz, cy, cx = rz[k], ry[k], rx[k]
        if not backward:
            if lz > k:
                lift_planes_kernel(az, one, cz, cy, cx, tmp, spec, backward)
            if ly > k:
                lift_planes_kernel(ay, cz, cy, one, cx, tmp, spec, backward)
            if lx > k:
                lift_rows_kernel(a, cz, cy, cx, tmp, spec, backward)
        else:
            if lx > k:
                lift_rows_kernel(a, cz, cy, cx, tmp, spec, backward)
            if ly > k:
                lift_planes_kernel(ay, cz, cy, one, cx, tmp, spec, backward)
            if lz > k:
                lift_planes_kernel(az, one, cz, cy, cx, tmp, spec, backward)


def _run(x: np.ndarray, levels, wavelet: str, backward: bool, overwrite: bool) -> np.ndarray:
    spec = _check_wavelet(wavelet)
    x = np.asarray(x)
    if x.ndim != 3:
        raise FormatError(f"expected a 3-D array, found {x.ndim} dimensions")
    if x.dtype not in WORK_DTYPES:
        raise FormatError(f"expected an int32 or int64 work array, found {x.dtype}")
    lz, ly, lx = _check_levels(x.shape, levels)
    native = x.dtype.newbyteorder("=")
    if overwrite and x.flags.c_contiguous and x.flags.writeable and x.dtype == native:
        out = x
    else:
        out = np.array(x, dtype=native, order="C", copy=True)
    if out.size and max(lz, ly, lx) > 0:
        tmp = np.empty(out.size // 2 + 1, dtype=out.dtype)
        dwt3_kernel(out, tmp, lz, ly, lx, spec, backward)
    return out


def forward(
    x: np.ndarray, levels: tuple[int, int, int], wavelet: str, *, overwrite: bool = False
) -> np.ndarray:
    """Reversible integer transform of a 3-D int32/int64 array, in the Mallat layout.

    Returns a C-contiguous array of the same shape and dtype: a new one, or ``x`` itself
    transformed in place when ``overwrite`` is set and ``x`` allows it (saves a copy).
    The dtype must hold every coefficient: choose it with :func:`work_dtype`.
    """
    return _run(x, levels, wavelet, False, overwrite)


def inverse(
    c: np.ndarray, levels: tuple[int, int, int], wavelet: str, *, overwrite: bool = False
) -> np.ndarray:
    """Exact inverse of :func:`forward`: ``inverse(forward(x, l, w), l, w) == x``."""
    return _run(c, levels, wavelet, True, overwrite)


def narrow(c: np.ndarray, dtype: np.dtype) -> np.ndarray | None:
    """Cast reconstructed voxels to ``dtype`` in one pass; None if any falls outside it.

    A corrupt stream can decode to values no voxel of ``dtype`` has; this catches them
    without a separate min/max pass.
    """
    dtype = np.dtype(dtype)
    info = np.iinfo(dtype)
    out = np.empty(c.shape, dtype=dtype)
    ok = _narrow_kernel(c.reshape(-1), out.reshape(-1), int(info.min), int(info.max))
    return out if ok else None


@kernel
def _narrow_kernel(src, dst, lo, hi):
    bad = False
    for i in range(src.size):
        v = src[i]
        bad |= (v < lo) | (v > hi)
        dst[i] = v
    return not bad


# --- coefficient growth -----------------------------------------------------------------


def _level_bound(wavelet: str, a: int, b: int):
    """Integer intervals holding every value one 1-D level stores, for inputs in [a, b].

    Returns ``(low, high)``; ``high`` also covers the 2/6 intermediate detail.
    Writing ``m = (a+b)/2`` and ``r = (b-a)/2``, an exact lifting output is a linear form
    ``sum c_i x_i`` plus the accumulated floor error; the form with gain ``G = sum c_i``
    and norm ``N = sum |c_i|`` lies in ``[G m - N r, G m + N r]``.
    """
    m, r = Fraction(a + b, 2), Fraction(b - a, 2)
    if wavelet in ("haar", "26"):
        # s = floor((x0 + x1) / 2) or an unpaired x: inside [a, b]; x1 - x0 in [a-b, b-a].
        low = (a, b)
        if wavelet == "haar":
            return low, (a - b, b - a)
        # d = (x1 - x0) + floor((s' - s'' + 2) / 4) with s', s'' in [a, b].
        return low, (a - b + (a - b + 2) // 4, b - a + (b - a + 2) // 4)
    if wavelet == "53":
        # d = x1 - floor((x0 + x2)/2): plain interval arithmetic, [a-b, b-a].
        # s = form (-1, 2, 6, 2, -1)/8 (G = 1, N = 3/2) plus an error in [-1/4, 3/4].
        high = (a - b, b - a)
        lo_err, hi_err = Fraction(-1, 4), Fraction(3, 4)
    else:  # "97m"
        # d = x1 - P(x) - 1/2 + e, P = (-1, 9, 9, -1)/16, e in [0, 15/16]: G = 0, N = 9/4.
        high = (
            math.ceil(-Fraction(9, 4) * r - Fraction(1, 2)),
            math.floor(Fraction(9, 4) * r + Fraction(7, 16)),
        )
        # s = form (1, 0, -8, 16, 46, 16, -8, 0, 1)/64 (G = 1, N = 3/2), error in
        # [-1/2, 23/32] (two detail errors in [-1/2, 7/16] over 4, plus the floor).
        lo_err, hi_err = Fraction(-1, 2), Fraction(23, 32)
    n = Fraction(3, 2)
    low = (math.ceil(m - n * r + lo_err), math.floor(m + n * r + hi_err))
    return low, high


@functools.lru_cache(maxsize=4096)
def coefficient_bound(
    lo: int, hi: int, levels: tuple[int, int, int], wavelet: str
) -> tuple[int, int]:
    """Return ``(min, max)`` bounding every value forward and inverse store, inputs in [lo, hi].

    Proof sketch. Every 1-D line that a level lifts lies inside one subband of the
    region (the split along an earlier axis does not mix lines), so it is enough to carry
    one interval per subband. For one 1-D level on values in ``[a, b]``:

    * 5/3 and 9/7-M with whole-sample symmetric extension compute exactly the lifting of
      the infinite mirrored signal, whose samples are also in ``[a, b]``; each output is
      therefore the interior linear form (exact gains and absolute sums, see
      :func:`_level_bound`) plus a bounded floor error.
    * Haar and 2/6 low-pass values are floored pair averages or copies (in ``[a, b]``);
      their details are differences plus, for 2/6, a quarter of a low-pass difference.

    The intervals are propagated over the subbands of every level and axis in transform
    order, and the union of all of them (the input range included) is returned. The
    inverse passes back through exactly the forward's states, so the bound covers it
    too. Across levels only the low-pass interval is carried (its correlation with the
    input is dropped), which is safe and loses a factor of at most (3/2)**(3*levels)
    for 5/3 and 9/7-M; Haar and 2/6 low-pass ranges do not grow at all.
    """
    if lo > hi:
        raise FormatError(f"expected lo <= hi, found lo={lo}, hi={hi}")
    _check_wavelet(wavelet)
    lmin, lmax = lo, hi
    lll = (lo, hi)
    for k in range(max(levels, default=0)):
        bands = [(lll, True)]
        for lv in levels:
            if lv <= k:
                continue
            new = []
            for (a, b), is_low in bands:
                low, high = _level_bound(wavelet, a, b)
                new.append((low, is_low))
                new.append((high, False))
                lmin = min(lmin, low[0], high[0])
                lmax = max(lmax, low[1], high[1])
            bands = new
        lll = next(iv for iv, is_low in bands if is_low)
    return lmin, lmax


def work_dtype(lo: int, hi: int, levels: tuple[int, int, int], wavelet: str) -> np.dtype:
    """The integer dtype to run :func:`forward` / :func:`inverse` in, for data in [lo, hi].

    int32 when :func:`coefficient_bound` proves that every stored value fits int32 (the
    kernels compute in int64 registers, so only stored values matter), else int64, which
    also must be proven (a 32-bit range with very deep levels would not be).

    With full levels, 5/3 and 9/7-M give int32 for 8-bit data up to 12 levels and for
    16-bit data up to 8 levels (256 voxels per axis); Haar and 2/6 give int32 for any
    16-bit data at any depth. 32-bit data always needs int64.
    """
    levels = tuple(int(v) for v in levels)
    bmin, bmax = coefficient_bound(int(lo), int(hi), levels, wavelet)
    if _I32.min <= bmin and bmax <= _I32.max:
        return np.dtype(np.int32)
    if -_I64_SAFE <= bmin and bmax <= _I64_SAFE:
        return np.dtype(np.int64)
    raise FormatError(
        f"the {wavelet} transform with levels {levels} of data in [{lo}, {hi}] may need "
        f"coefficients up to {max(-bmin, bmax)}, more than int64 can safely hold; use fewer levels"
    )
