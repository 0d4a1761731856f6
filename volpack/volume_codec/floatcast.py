"""A float64 reconstruction clipped to float32's finite range and cast, in one pass (and
the integer quantised voxels rebuilt, clipped and cast the same way).

The lossy decoders rebuild voxels in double precision and hand back the volume's dtype.
``np.clip`` then ``astype`` walk the array twice and allocate twice; this kernel does
both in one walk with the same results: values past ``+-big`` become ``+-big``, NaN
stays NaN (as ``np.clip`` leaves it) and the cast rounds to nearest like numpy's.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, read_only

_U = np.uint64


@kernel(nrt=False)
def _clip_cast(v, out, big):
    for i in range(v.size):
        x = v[_U(i)]
        if x > big:
            x = big
        elif x < -big:
            x = -big
        out[_U(i)] = x


@kernel(nrt=False)
def _clip_cast_3d(v, out, big):
    """:func:`_clip_cast` between 3-D views of any strides (the interpolation path's
    walk array with its axes put back; a brick of a larger volume)."""
    nz, ny, nx = v.shape
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                t = v[_U(z), _U(y), _U(x)]
                if t > big:
                    t = big
                elif t < -big:
                    t = -big
                out[_U(z), _U(y), _U(x)] = t


def to_float32(v: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``np.clip(v, -big, big).astype(np.float32)`` for a float64 ``v`` (``big`` the
    largest finite float32), written into ``out`` (float32 of ``v``'s shape) when given;
    either may have any strides when both are 3-D, else both are C-contiguous."""
    if out is None:
        out = np.empty(v.shape, np.float32)
    big = float(np.finfo(np.float32).max)
    if v.flags.c_contiguous and out.flags.c_contiguous:
        _clip_cast(v.reshape(-1), out.reshape(-1), big)
    else:  # a transposed walk, or a brick inside a larger volume: one pass all the same
        _clip_cast_3d(v, out, big)
    return out


@kernel(nrt=False)
def _dequantise_3d(q, step, lo, out, big):
    """``out = to_float32(q * step + lo)``: the quantised voxels rebuilt in double
    precision (the same two IEEE operations) and cast, one pass between 3-D views."""
    nz, ny, nx = q.shape
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                t = np.float64(q[_U(z), _U(y), _U(x)]) * step
                t = t + lo
                if t > big:
                    t = big
                elif t < -big:
                    t = -big
                out[_U(z), _U(y), _U(x)] = t


@kernel(nrt=False)
def _dequantise_flat(q, step, lo, out, big):
    """:func:`_dequantise_3d` of C-contiguous arrays, flat: one loop the compiler can
    vectorise (on the short rows of small fields the 3-D loop took 0.4-0.5 ns a voxel,
    this one 0.2), the same operations a voxel."""
    for i in range(q.size):
        t = np.float64(q[_U(i)]) * step
        t = t + lo
        if t > big:
            t = big
        elif t < -big:
            t = -big
        out[_U(i)] = t


def dequantise_float32(q: np.ndarray, step: float, lo: float, out: np.ndarray | None = None):
    """``to_float32(q.astype(np.float64) * step + lo)`` for a 3-D integer ``q`` without
    the float64 temporary, into ``out`` (float32, ``q``'s shape, any strides) when
    given."""
    if out is None:
        out = np.empty(q.shape, np.float32)
    big = float(np.finfo(np.float32).max)
    if q.flags.c_contiguous and out.flags.c_contiguous:
        _dequantise_flat(read_only(q).reshape(-1), float(step), float(lo), out.reshape(-1), big)
    else:  # a brick inside a larger volume
        _dequantise_3d(read_only(q), float(step), float(lo), out, big)  # one signature per dtype
    return out


@kernel(nrt=False)
def _scale_over(q, c, step):
    for i in range(q.size):
        c[_U(i)] = np.float64(q[_U(i)]) * step  # (read before written: same index)


def scale_in_place(q: np.ndarray, step: float) -> np.ndarray:
    """``q * step`` (float64) for a C-contiguous int64 ``q``, written over ``q``'s own
    memory (returned as a float64 view of it): no second brick-sized array."""
    c = q.view(np.float64)
    _scale_over(q.reshape(-1), c.reshape(-1), float(step))
    return c


@kernel(nrt=False)
def _dequantise_int_3d(q, step, lo, out, vmin, vmax):
    """``out = clip(q * step + lo, vmin, vmax)`` in 64-bit integers, one pass between
    3-D views."""
    nz, ny, nx = q.shape
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                t = np.int64(q[_U(z), _U(y), _U(x)]) * step + lo
                if t > vmax:
                    t = vmax
                elif t < vmin:
                    t = vmin
                out[_U(z), _U(y), _U(x)] = t


@kernel(nrt=False)
def _dequantise_int_flat(q, step, lo, out, vmin, vmax):
    """:func:`_dequantise_int_3d` of C-contiguous arrays, flat."""
    for i in range(q.size):
        t = np.int64(q[_U(i)]) * step + lo
        if t > vmax:
            t = vmax
        elif t < vmin:
            t = vmin
        out[_U(i)] = t


def dequantise_integer(q: np.ndarray, step: int, lo: int, dtype, out: np.ndarray | None = None):
    """``np.clip(q.astype(np.int64) * step + lo, min, max).astype(dtype)`` (the integer
    ``dtype``'s range) for a 3-D integer ``q`` without the int64 temporaries (the
    bounded codec's integer reconstruction: a third of the fast coding's decode time
    as three numpy passes), into ``out`` (``q``'s shape, any strides) when given."""
    info = np.iinfo(dtype)
    if out is None:
        out = np.empty(q.shape, dtype)
    args = (int(step), int(lo))
    if q.flags.c_contiguous and out.flags.c_contiguous:  # (as in dequantise_float32)
        _dequantise_int_flat(
            read_only(q).reshape(-1), *args, out.reshape(-1), int(info.min), int(info.max)
        )
    else:
        _dequantise_int_3d(read_only(q), *args, out, int(info.min), int(info.max))
    return out
