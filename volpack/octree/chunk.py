"""A node's chunk decoded in one kernel call: the entropy decoder (``arith``), the
details' energy check, the low-pass corner and the inverse lifting, without the GIL.

Step by step (``Octree._lift_up``'s Python path) a chunk was two kernels between a
dozen numpy and Python steps that hold the GIL (an int64 buffer zeroed and copied back,
the energy on 32^3 float64 temporaries, the table rows looked up node by node): on a
walk's first frame two threads decoded only 1.3-1.5x as fast as one, each blocked
about a third of its time taking the GIL back (README, walk14). Here the Python side
is a cache lookup, the payload read and this call; the numbers are the step-by-step
path's (the energy summed in numpy's pairwise order, its bounds with numpy's sums),
so the same chunks pass, and the same voxels come out.
"""

from __future__ import annotations

import functools

import numpy as np

from .._jit import kernel
from ..entropy.arith import context_table, decode_tabled_kernel
from ..wavelet.dwt3 import dwt3_kernel
from ..wavelet.sigmap import scan as make_scan

#: statuses besides the entropy decoder's own 1-3
ENERGY_MISMATCH = 4

_BLOCK = 128  # numpy's pairwise summation: blocks of 8 running sums up to this length


@kernel(inline=True)
def _energy_leaf(flat, scale, start, n):
    """numpy's ``pairwise_sum`` of ``n <= 128`` squares: 8 running sums, then the rest."""
    if n < 8:
        res = -0.0
        for i in range(start, start + n):
            x = np.float64(flat[i]) * scale[i]
            res += x * x
        return res
    r = np.empty(8)
    for j in range(8):
        x = np.float64(flat[start + j]) * scale[start + j]
        r[j] = x * x
    i = 8
    while i < n - (n % 8):
        for j in range(8):
            x = np.float64(flat[start + i + j]) * scale[start + i + j]
            r[j] += x * x
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        x = np.float64(flat[start + i]) * scale[start + i]
        res += x * x
        i += 1
    return res


@kernel
def _energy_sum(flat, scale):
    """``np.sum(np.square(flat * scale))`` in numpy's order (``pairwise_sum`` of its
    float loops: halves cut at multiples of 8 down to blocks of at most 128), the squares
    made as they are read. A stack, not recursion (numba's cached recursive kernels
    crashed when loaded)."""
    todo = np.empty((128, 3), np.int64)  # (start, n, halves done); depth ~ 2 log2(n / 128)
    vals = np.empty(64)
    t, v = 0, 0
    todo[0, 0], todo[0, 1], todo[0, 2] = 0, flat.size, 0
    t = 1
    while t:
        t -= 1
        s, n, done = todo[t, 0], todo[t, 1], todo[t, 2]
        if n <= _BLOCK:
            vals[v] = _energy_leaf(flat, scale, s, n)
            v += 1
        elif done:
            v -= 1
            vals[v - 1] = vals[v - 1] + vals[v]
        else:
            n2 = n // 2
            n2 -= n2 % 8
            todo[t, 0], todo[t, 1], todo[t, 2] = s, n, 1
            todo[t + 1, 0], todo[t + 1, 1], todo[t + 1, 2] = s + n2, n - n2, 0
            todo[t + 2, 0], todo[t + 2, 1], todo[t + 2, 2] = s, n2, 0
            t += 3
    return 0.0 + vals[0]


@kernel
def _chunk_kernel(data, perm, end, ctab, cls, nmax, scale, norm, lo, hi, low, c, lz, ly, lx, spec):
    """Decode the details ``data`` (empty: none) into ``c`` (zeroed here), check their
    energy against ``[lo, hi]``, put ``low`` in the corner and lift ``c`` back in place.
    Returns 0, the decoder's status or :data:`ENERGY_MISMATCH` (``c`` then unfinished)."""
    n = c.size
    flat = c.reshape(n)  # decoded in place: a bit length of at most nmax fits the work dtype
    flat[:] = 0
    if data.size:
        status = decode_tabled_kernel(data, perm, end, ctab, cls, flat, nmax)
        if status != 0:
            return status
    own = _energy_sum(flat, scale) * norm * norm
    if not (lo <= own <= hi):
        return ENERGY_MISMATCH
    nz, ny, nx = low.shape
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                c[z, y, x] = low[z, y, x]
    tmp = np.empty(n // 2 + 1, c.dtype)
    backward = n > 0  # a runtime bool: a literal True compiled the lifting anew (10 s)
    dwt3_kernel(c, tmp, lz, ly, lx, spec, backward)
    return 0


@functools.lru_cache(maxsize=64)
def chunk_scan(shape, levels, order: str):
    """``(scan, its arith context table)`` of a child block (both made once)."""
    s = make_scan(shape, levels, order)
    return s, context_table(s)


def decode_chunk(data, scan, nmax: int, scale, norm: float, bounds, low, c, levels, spec) -> int:
    """Fill ``c`` (C-contiguous work integers of the node's child block) with the
    children's voxels: details ``data`` (uint8 array, empty for none) in the order of
    ``scan`` (:func:`chunk_scan`'s pair), their energy ``sum((c scale)^2) norm^2``
    checked within ``bounds``, ``low`` in the low-pass corner, one inverse lifting level
    ``levels`` of wavelet table ``spec``. Returns 0, or the status that sends the
    caller to the step-by-step path."""
    s, ctab = scan
    return int(_chunk_kernel(data, s.perm, s.end, ctab, s.cls, nmax, scale, norm, bounds[0],
                             bounds[1], low, c, *levels, spec))  # fmt: skip


@kernel(inline=True)
def _down(v):
    """The next float32 below ``v`` (float32), not below 0, as float64."""
    return np.float64(np.maximum(np.nextafter(v, np.float32(-np.inf)), np.float32(0)))


@kernel
def _bounds_kernel(e, kids, grid, kgrid, lo, hi):
    # layout.own_energy_range per node, kids in itertools.product order; numpy sums 8
    # values as ((k0 + k1) + (k2 + k3)) + ((k4 + k5) + (k6 + k7)), fewer one by one
    gy, gx = grid[1], grid[2]
    a = np.empty(8)
    b = np.empty(8)
    for node in range(e.size):
        iz, iy, ix = node // (gy * gx), (node // gx) % gy, node % gx
        m = 0
        if kids.size:
            for dz in range(2):
                for dy in range(2):
                    for dx in range(2):
                        z, y, x = 2 * iz + dz, 2 * iy + dy, 2 * ix + dx
                        if z < kgrid[0] and y < kgrid[1] and x < kgrid[2]:
                            k = kids[(z * kgrid[1] + y) * kgrid[2] + x]
                            a[m] = np.float64(k) * np.float64(k)
                            d = _down(k)
                            b[m] = d * d
                            m += 1
        if m == 8:
            sa = ((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))
            sb = ((b[0] + b[1]) + (b[2] + b[3])) + ((b[4] + b[5]) + (b[6] + b[7]))
        else:
            sa = -0.0
            sb = -0.0
            for j in range(m):
                sa += a[j]
                sb += b[j]
        ee = np.float64(e[node])
        de = _down(e[node])
        slack = 1e-9 * (ee * ee)
        lo[node] = (de * de - (0.0 + sa)) - slack
        hi[node] = (ee * ee - (0.0 + sb)) + slack


def energy_bounds(e, kids, grid, kgrid) -> tuple[np.ndarray, np.ndarray]:
    """``layout.own_energy_range`` of every node of a level at once: its table's ``E``
    (``grid`` nodes) and the finer level's (``kgrid``; empty for level 1), the same
    numbers as node by node."""
    e = np.ascontiguousarray(e, np.float32)
    kids = np.ascontiguousarray(kids, np.float32)
    lo, hi = np.empty(e.size), np.empty(e.size)
    _bounds_kernel(e, kids, np.array(grid, np.int64), np.array(kgrid, np.int64), lo, hi)
    return lo, hi
