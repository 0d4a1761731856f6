"""Floats as ordered integers: the exact, order-keeping map a lossless float coder needs.

An IEEE float's bits, read as a signed-magnitude number, order like the floats: flipping
every bit of a negative float and only the sign bit of a positive one gives an unsigned
integer that grows with the float (``-Inf < -1 < -0.0 < +0.0 < denormals < 1 < +Inf <
NaN``). The map is a bijection on bit patterns, so NaN payloads, ``-0.0`` and
denormals come back exactly; a predictor on these integers sees a smooth field as a
smooth sequence.
"""

from __future__ import annotations

import numpy as np

FLOAT_DTYPES = ("float16", "float32")  # whose ordered image fits the predictor's range


def to_signed(a: np.ndarray) -> np.ndarray:
    """Float array -> int64 array of the signed ordered images of its bit patterns: the
    bits as a signed integer, every bit but the sign flipped where it is set (-0.0 is -1,
    +0.0 is 0). Fits int64 for float64 too."""
    b = 8 * a.dtype.itemsize
    i = np.ascontiguousarray(a).view(f"i{a.dtype.itemsize}").astype(np.int64)
    return np.where(i < 0, i ^ np.int64((1 << (b - 1)) - 1), i)


def from_signed(s: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The inverse of :func:`to_signed` (``s`` in the signed range of the float's width)."""
    dtype = np.dtype(dtype)
    b = 8 * dtype.itemsize
    i = np.where(s < 0, s ^ np.int64((1 << (b - 1)) - 1), s)
    return i.astype(f"i{dtype.itemsize}").view(dtype)


def to_ordered(a: np.ndarray) -> np.ndarray:
    """Float array -> int64 array of the ordered images of its bit patterns: the signed
    images moved up by half the range (``0..2^bits - 1``; floats up to 32 bits)."""
    return to_signed(a) + (np.int64(1) << (8 * a.dtype.itemsize - 1))


def from_ordered(v: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The inverse of :func:`to_ordered`; like it, reads ``v`` modulo ``2^bits``."""
    dtype = np.dtype(dtype)
    bits = 8 * dtype.itemsize
    low = np.asarray(v, dtype=np.int64) & ((np.int64(1) << bits) - 1)
    return from_signed(low - (np.int64(1) << (bits - 1)), dtype)
