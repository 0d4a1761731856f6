"""Trilinear resampling of a coarse node onto a finer level (``Octree.assemble`` with
``interp="linear"``): a kernel doing numpy's three axis passes in one sweep.

Each pass blends two source planes along one axis, ``a (1 - w) + c w`` in float64 with
no fused multiply-add, so the result is the same number the pass-by-pass numpy form
gives; integer outputs are rounded to nearest (ties to even) and clipped to the dtype's
range in the kernel, so the caller's cast is exact. In numpy, the passes over the
coarse nodes of a walk's first frame (21 M voxels of the MRI of the benchmark) took
0.5 CPU s, most of the frame's node writes; here about 3 ns a voxel.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel


@kernel
def _trilinear_kernel(v, z0, z1, wz, y0, y1, wy, x0, x1, wx, rounded, lo, hi, out):
    # one output plane at a time: its z blend and y blend stay in two small buffers
    # (the three passes over whole arrays took 50 % longer on the MRI walk's boxes)
    nz, ny, nx = len(z0), len(y0), len(x0)
    sy, sx = v.shape[1], v.shape[2]
    a = np.empty((sy, sx))
    b = np.empty((ny, sx))
    for i in range(nz):
        w = wz[i]
        p, q = z0[i], z1[i]
        for j in range(sy):
            for k in range(sx):
                a[j, k] = v[p, j, k] * (1 - w) + v[q, j, k] * w
        for j in range(ny):
            w = wy[j]
            p, q = y0[j], y1[j]
            for k in range(sx):
                b[j, k] = a[p, k] * (1 - w) + a[q, k] * w
        for j in range(ny):
            for k in range(nx):
                w = wx[k]
                r = b[j, x0[k]] * (1 - w) + b[j, x1[k]] * w
                if rounded:
                    r = min(max(np.rint(r), lo), hi)
                out[i, j, k] = r


def trilinear(v: np.ndarray, j0, j1, w, dtype, into=None) -> np.ndarray:
    """``v`` (float64, 3-D) resampled at positions between voxels ``j0[ax]`` and
    ``j1[ax]`` with weights ``w[ax]`` of the second, per axis; the result in ``dtype``
    (integers rounded and clipped to its range), or cast into ``into`` (exact for an
    integer ``into`` of ``dtype``: the values are whole and within its range)."""
    dtype = np.dtype(dtype)
    rounded = dtype.kind in "iu"
    info = np.iinfo(dtype) if rounded else None
    # an integer ``into`` of ``dtype`` is written by the kernel itself: its values are
    # whole and in range, so the store converts them exactly (a walk's first frame wrote
    # 21 M voxels through a float64 copy and a cast pass otherwise)
    direct = rounded and into is not None and into.dtype == dtype
    out = into if direct else np.empty(tuple(len(j) for j in j0))
    _trilinear_kernel(np.ascontiguousarray(v, np.float64),
                      *(np.ascontiguousarray(x, t) for ax in range(3)
                        for x, t in ((j0[ax], np.int64), (j1[ax], np.int64), (w[ax], np.float64))),
                      rounded, float(info.min) if rounded else 0.0,
                      float(info.max) if rounded else 0.0, out)  # fmt: skip
    if into is not None:
        if not direct:
            into[...] = out
        return into
    return out.astype(dtype)


@kernel
def _axis_kernel(start, fm, n, j0, j1, w):
    # numpy's per-axis steps of Octree.resampled, the same operations in the same order
    for k in range(j0.size):
        p = (np.float64(start + k) + 0.5) / fm - 0.5
        j = np.int64(min(max(np.floor(p), 0.0), n - 1.0))
        j0[k] = j
        j1[k] = min(j + 1, n - 1)
        w[k] = min(max(p - np.float64(j), 0.0), 1.0)
    base = j0[0]  # both nondecreasing: the first is the least
    for k in range(j0.size):
        j0[k] -= base
        j1[k] -= base
    return base


def axis_weights(start: int, stop: int, fm: int, n: int):
    """The level voxels (``j0``, ``j1``) between which the centres of voxels
    ``start:stop`` of a level ``fm`` times finer lie, and the weight ``w`` of the
    second, on an axis of ``n`` level voxels (clamped at its ends): ``(base, j0, j1,
    w)`` with the voxels counted from ``base``. The numbers of ``pos = (i + 0.5) / fm -
    0.5; j0 = clip(floor(pos), 0, n - 1); j1 = min(j0 + 1, n - 1); w = clip(pos - j0,
    0, 1)`` in numpy, in one call (those were 15 numpy calls a box)."""
    m = stop - start
    j0, j1, w = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m)
    base = _axis_kernel(start, fm, n, j0, j1, w)
    return int(base), j0, j1, w


@kernel
def _put_kernel(src, lo, hi, out):
    nz, ny, nx = src.shape
    for i in range(nz):
        for j in range(ny):
            for k in range(nx):
                out[i, j, k] = min(max(src[i, j, k], lo), hi)


def put_clipped(src: np.ndarray, lo: int, hi: int, out: np.ndarray) -> None:
    """``out[...] = np.clip(src, lo, hi)`` for integer ``src`` (``to_values`` of a
    plain integer tree, ``out`` of its dtype or float64: the same numbers) in one kernel
    call: the numpy form took 20-30 us of Python a block, 3608 blocks a walk's first
    frame."""
    _put_kernel(src, lo, hi, out)
