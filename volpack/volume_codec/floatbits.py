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


def to_ordered(a: np.ndarray) -> np.ndarray:
    """Float array -> int64 array of the ordered images of its bit patterns."""
    bits = 8 * a.dtype.itemsize
    u = np.ascontiguousarray(a).view(f"u{a.dtype.itemsize}").astype(np.int64)
    sign = np.int64(1) << (bits - 1)
    full = (np.int64(1) << bits) - 1
    return np.where(u & sign, u ^ full, u | sign)


def from_ordered(v: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The inverse of :func:`to_ordered` (``v`` in ``0..2^bits - 1``)."""
    dtype = np.dtype(dtype)
    bits = 8 * dtype.itemsize
    sign = np.int64(1) << (bits - 1)
    full = (np.int64(1) << bits) - 1
    u = np.where(v & sign, v ^ sign, v ^ full)
    return u.astype(f"u{dtype.itemsize}").view(dtype)
