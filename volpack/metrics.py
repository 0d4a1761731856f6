"""How close a decoded volume is to its original, and what the compression cost.

Errors are computed chunk by chunk in a type wide enough for every input: exact 64-bit
integer differences for integer pairs (so ``uint8`` 0 against 255 is 255, never a wrapped
1) and float64 otherwise. An optional ``mask`` (True = leave out, as ``Volume.mask``)
removes voxels that hold no measurement. Among the voxels that remain, a float special
value matching the same special in the other array (NaN with NaN, +Inf with +Inf) counts
as an exact match; any other pairing with a special value is an infinite error.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .errors import OptionError

_CHUNK = 1 << 22  # voxels per pass: bounds the float64 temporaries to a few tens of MB


def max_error(a, b, mask=None) -> float:
    """Return the largest absolute difference ``max |a - b|`` over the valid voxels.

    Parameters
    ----------
    a, b : array_like of the same shape
        Original and reconstruction, any integer or float dtype.
    mask : array_like of bool, optional
        True marks voxels to leave out.

    Returns
    -------
    float
        0.0 when no voxel is valid; ``inf`` when a special value is not matched.
    """
    return _error_stats(a, b, mask)[0]


def rmse(a, b, mask=None) -> float:
    """Return the root mean square difference over the valid voxels (0.0 when none)."""
    _, sq, n, scale = _error_stats(a, b, mask)
    return _rmse(sq, n, scale)


def psnr(a, b, *, peak=None, mask=None) -> float:
    """Return the peak signal-to-noise ratio ``20 log10(peak) - 10 log10(mse)`` in dB.

    Parameters
    ----------
    a, b : array_like of the same shape
        Original and reconstruction.
    peak : float, optional
        Signal peak. Default: the value range ``max - min`` of the finite valid voxels of
        the original ``a``, the convention of scientific compressors (zfp, SZ, SPERR).
        Image codecs use the dtype's maximum instead (255 for 8 bits); pass it here to
        compare with them.
    mask : array_like of bool, optional
        True marks voxels to leave out.

    Returns
    -------
    float
        ``inf`` when the valid voxels are equal; ``-inf`` when the peak is 0 but they
        differ.
    """
    _, sq, n, scale = _error_stats(a, b, mask)
    return _psnr(sq, n, scale, a, peak, mask)


def ratio(raw_nbytes: int, compressed_nbytes: int) -> float:
    """Return the compression ratio ``raw / compressed``."""
    if compressed_nbytes <= 0 or raw_nbytes < 0:
        raise OptionError(
            f"expected sizes raw >= 0 and compressed > 0, found {raw_nbytes!r}, {compressed_nbytes!r}"
        )
    return raw_nbytes / compressed_nbytes


def bits_per_voxel(compressed_nbytes: int, nvoxels: int) -> float:
    """Return the compressed size in bits per voxel."""
    if nvoxels <= 0 or compressed_nbytes < 0:
        raise OptionError(
            f"expected nbytes >= 0 and nvoxels > 0, found {compressed_nbytes!r}, {nvoxels!r}"
        )
    return 8.0 * compressed_nbytes / nvoxels


def throughput(nbytes: int, seconds: float) -> float:
    """Return the speed in MB/s, with MB = 1e6 bytes (``inf`` for a zero duration)."""
    if seconds < 0 or nbytes < 0:
        raise OptionError(f"expected nbytes >= 0 and seconds >= 0, found {nbytes!r}, {seconds!r}")
    return math.inf if seconds == 0 else nbytes / 1e6 / seconds


def summary(a, b, compressed_nbytes=None, mask=None) -> dict[str, Any]:
    """Return ``psnr``, ``rmse``, ``max_error`` (and ``ratio``, ``bpv`` when the compressed
    size is given) as plain Python floats, from one pass over the data."""
    a = np.asarray(a)
    mx, sq, n, scale = _error_stats(a, b, mask)
    out: dict[str, Any] = {
        "psnr": _psnr(sq, n, scale, a, None, mask),
        "rmse": _rmse(sq, n, scale),
        "max_error": mx,
    }
    if compressed_nbytes is not None:
        out["ratio"] = ratio(a.nbytes, compressed_nbytes)
        out["bpv"] = bits_per_voxel(compressed_nbytes, a.size)
    return out


def chunks(*arrays):
    """The arrays flat, ``_CHUNK`` voxels of each at a time (a None stays None): a
    whole-volume temporary of a big volume (a selection, a difference, a bool test)
    costs several times its size."""
    flat = [None if x is None else np.asarray(x).reshape(-1) for x in arrays]
    size = next(x.size for x in flat if x is not None)
    for s in range(0, size, _CHUNK):
        yield tuple(None if x is None else x[s : s + _CHUNK] for x in flat)


# --- private ---------------------------------------------------------------------------


def _prepare(a, b, mask):
    a, b = np.asarray(a), np.asarray(b)
    if a.shape != b.shape:
        raise OptionError(f"expected arrays of the same shape, found {a.shape} and {b.shape}")
    for x in (a, b):
        if x.dtype.kind not in "biuf":
            raise TypeError(f"expected integer or float arrays, found dtype {x.dtype}")
    if mask is not None:
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != a.shape:
            raise OptionError(f"expected a mask of shape {a.shape}, found {mask.shape}")
        mask = mask.reshape(-1)
    return a.reshape(-1), b.reshape(-1), mask


def _abs_diff(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``|a - b|`` exactly for integers (uint64 or int64), in float64 otherwise."""
    if a.dtype.kind in "biu" and b.dtype.kind in "biu":
        small = a.dtype.itemsize < 8 and b.dtype.itemsize < 8
        if small or a.dtype == b.dtype:
            if small:
                a, b = a.astype(np.int64), b.astype(np.int64)
            # hi - lo lies in [0, 2**64): modular uint64 subtraction is exact
            hi, lo = np.maximum(a, b), np.minimum(a, b)
            return hi.astype(np.uint64) - lo.astype(np.uint64)
    with np.errstate(invalid="ignore", over="ignore"):  # specials are sorted out below
        d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    if a.dtype.kind == "f" or b.dtype.kind == "f":
        bad = ~np.isfinite(d)
        if bad.any():
            same = (a == b) | (np.isnan(a) & np.isnan(b))
            d[bad] = np.where(same[bad], 0.0, np.inf)
    return d


def _error_stats(a, b, mask) -> tuple[float, float, int, float]:
    """Return (max abs error, sum of squared errors / scale**2, valid voxel count, scale).

    The squares are summed in units of ``scale``, a power of two at or above the largest
    finite error so far (the sum rescaled when a chunk raises it): errors of float64 data
    near 1e300 would overflow squared, yet their RMSE and PSNR are ordinary numbers."""
    a, b, mask = _prepare(a, b, mask)
    mx, sq, n, scale = 0.0, 0.0, 0, 1.0
    for ca, cb, cm in chunks(a, b, mask):
        if cm is not None:
            ca, cb = ca[~cm], cb[~cm]
        if ca.size == 0:
            continue
        d = _abs_diff(ca, cb)
        top = float(d.max())
        mx = max(mx, top)
        if math.isinf(top):
            sq = math.inf
        elif top > scale:
            grown = math.ldexp(1.0, math.frexp(top)[1])  # exact powers of two: no rounding
            sq *= (scale / grown) ** 2
            scale = grown
        f = d.astype(np.float64) / scale
        sq += float(np.dot(f, f))
        n += int(ca.size)
    return mx, sq, n, scale


def _rmse(sq: float, n: int, scale: float) -> float:
    return scale * math.sqrt(sq / n) if n else 0.0


def psnr_from_sse(sse: float, n: int, peak: float) -> float:
    """Return the PSNR in dB of ``n`` voxels whose squared errors sum to ``sse``, for
    ``peak`` (the value range): ``inf`` when nothing differs, ``-inf`` when voxels differ
    and the peak is 0 (or the error is infinite). Every summary volpack writes takes its
    PSNR from here."""
    if n == 0 or sse == 0.0:
        return math.inf
    mse = sse / n
    if mse == math.inf or not peak > 0:
        return -math.inf
    peak = float(peak)
    if peak * peak == math.inf:  # the square overflows: the same value in two logarithms
        return 20.0 * math.log10(peak) - 10.0 * math.log10(mse)
    return 10.0 * math.log10(peak * peak / mse)


def _psnr(sq: float, n: int, scale: float, a, peak, mask) -> float:
    """The PSNR of ``sq`` (squared errors in units of ``scale``): the peak is divided by
    the same scale, so neither square overflows."""
    if peak is None and n and sq:
        peak = _value_range(a, mask)
    return psnr_from_sse(sq, n, peak / scale if peak is not None else None)


def _value_range(a, mask) -> float:
    """Return ``max - min`` of the finite valid voxels of ``a`` (0.0 when none), a chunk
    at a time: the selected values of a whole volume would be a copy of it."""
    a = np.asarray(a)
    mask = None if mask is None else np.asarray(mask, dtype=bool)
    lo = hi = None
    for c, cm in chunks(a, mask):
        if cm is not None:
            c = c[~cm]
        if c.dtype.kind == "f":
            c = c[np.isfinite(c)]
        if c.size:
            lo = c.min() if lo is None else min(lo, c.min())
            hi = c.max() if hi is None else max(hi, c.max())
    if lo is None:
        return 0.0
    if a.dtype.kind in "biu":
        return float(int(hi) - int(lo))
    return float(hi) - float(lo)
