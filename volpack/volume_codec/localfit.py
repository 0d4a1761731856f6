"""A least-squares predictor refitted along every row on its causal neighbourhood.

:mod:`.predictfit` fits one set of 16 weights per gradient class for a whole brick and
blends it with five fixed predictors by their recent errors. A scan's local structure
(an edge's direction, a texture, the noise level) changes faster than that: a predictor
over the same 16 neighbours plus a constant, refitted on the voxels just coded (the
``R`` rows above within ``R`` columns, the ``R`` voxels left of it in its row, and the
slice before within ``RU`` rows and columns), follows it. It is refitted at every
second voxel of a row (at even ``x - 2``) and the weights serve that voxel and the next:
solving the system is most of the cost, and the window moves by one column in between
(fitting at every voxel saved 0.01-0.3 % more on six scans, for 1.4x the time).
Weighted against the blend it saves 0.3-10 % of the predictive stream's bytes on MRIs and
CT (more on the smoother ones; 16 % on a k-means label map).

The decoder must repeat every fit bit for bit, on any machine. The normal equations are
sums of products of integers: the values are below ``2^MAX_BITS``, a product below
2^40 and a window's sum (at most 89 training voxels, and a column on its way in) below
2^47, so float64 holds every sum exactly whatever the order of the additions. They are
moved as the window slides: a sum per column over the window's rows, in the slice and
in the slice before, updated when a row starts, and the window's sum updated by a
column in and a column out at each voxel. Only the solve rounds: a Cholesky
factorisation of the 17 x 17 system with a ridge of ``RIDGE`` times its mean diagonal,
then the two triangular solves, in IEEE binary64 with the operations in the order
written and none fused (the kernels compile without fast-math), so every platform
rounds them alike.

An estimate is made where every neighbour exists (slices from 2, rows and columns from 2
to the second last) and the window holds at least ``MIN_SAMPLES`` training voxels not all
of one value (a flat background: the blend has it already); elsewhere there is none
(``NONE``). It is in eighths, not clipped (the caller clips).
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel

R = 4  # the window in the voxel's slice: R rows above, columns within R
RU = 3  # the window in the slice before: rows and columns within RU
NF = 17  # 16 neighbours and a constant
NG = NF + 1  # and the target: the products kept are those of this vector
NQ = NG * (NG + 1) // 2  # its upper triangle
MIN_SAMPLES = 40
RIDGE = 1e-3
MAX_BITS = 20  # values below 2^20: every sum is an integer below 2^47 (exact in float64)
NONE = -(1 << 62)
N_AT = (NF - 1) * NG - (NF - 1) * (NF - 2) // 2  # the training voxels' count: products 1 x 1
T_AT, TT_AT = N_AT + 1, N_AT + 2  # the sums of the targets and of their squares
W_AT = NF * NF  # where the solve leaves the weights in its workspace


def steps(offsets, shape) -> np.ndarray:
    """The flat index steps back to the 16 neighbours ((dz, dy, dx) ``offsets``)."""
    _, ny, nx = shape
    return np.array([dz * ny * nx + dy * nx + dx for dz, dy, dx in offsets], dtype=np.int64)


def workspace(shape) -> tuple[np.ndarray, ...]:
    """The column sums of the slice and the slice before (``2 nx NQ``), the window's
    sums, the system (``NF x NF``, then its right-hand side, which becomes the
    weights) and two training vectors (``2 NG``)."""
    nx = shape[2]
    return (
        np.zeros(2 * nx * NQ, dtype=np.float64),
        np.zeros(NQ, dtype=np.float64),
        np.zeros(NF * NF + NF, dtype=np.float64),
        np.zeros(2 * NG, dtype=np.float64),
    )


def usable(shape, hi: int) -> bool:
    """Whether a brick has voxels to estimate and values small enough for exact sums."""
    nz, ny, nx = shape
    return nz >= 3 and ny >= 5 and nx >= 5 and hi < (1 << MAX_BITS)


@kernel(inline=True)
def _vector(g, off, v, i, st):
    """Training voxel ``i``'s vector (its neighbours, 1, itself) into ``g[off:off +
    NG]``; zeros for ``i`` < 0 (no voxel)."""
    if i < 0:
        for k in range(NG):
            g[off + k] = 0.0
        return
    for k in range(NF - 1):
        g[off + k] = np.float64(v[np.uint64(i - st[k])])
    g[off + NF - 1] = 1.0
    g[off + NF] = np.float64(v[np.uint64(i)])


@kernel(inline=True)
def _exchange(s, base, v, i_in, i_out, st, g):
    """Add the products of training voxel ``i_in``'s vector to the sums at
    ``s[base:base + NQ]`` and take away those of ``i_out`` (either -1: none), in one
    pass over the sums."""
    _vector(g, 0, v, i_in, st)
    _vector(g, NG, v, i_out, st)
    q = base
    for a in range(NG):
        ga = g[a]
        ha = g[NG + a]
        # (unsigned indices: no test for negative ones, so the loop vectorises)
        for c in range(np.uint64(a), np.uint64(NG)):
            s[np.uint64(q - a) + c] += ga * g[c] - ha * g[np.uint64(NG) + c]
        q += NG - a


@kernel(inline=True)
def _column_rows(cs, half, v, z, y_in, y_out, nx, sz, st, g):
    """Add row ``y_in`` of slice ``z`` to the column sums ``half`` (0: the voxel's
    slice, 1: the slice before) and take away row ``y_out`` (either -1: none)."""
    b_in = z * sz + y_in * nx
    b_out = z * sz + y_out * nx
    for x in range(2, nx - 1):
        i_in = b_in + x if y_in >= 0 else -1
        i_out = b_out + x if y_out >= 0 else -1
        _exchange(cs, (half * nx + x) * NQ, v, i_in, i_out, st, g)


@kernel(inline=True)
def _row(r, ny):
    """Row ``r`` if training voxels lie on it, else -1."""
    return r if 2 <= r <= ny - 2 else -1


@kernel(nrt=False)
def row_start(cs, v, z, y, ny, nx, st, g):
    """Move the column sums to row ``y`` of slice ``z`` (``z >= 2``; called for every
    row in order): the slice's hold rows ``[max(2, y - R), y - 1]``, the slice before's
    ``[max(2, y - RU), min(ny - 2, y + RU)]`` (none when that slice is 2: its voxels'
    neighbours two slices back do not exist)."""
    sz = ny * nx
    before = z >= 3
    if y == 0:
        for q in range(cs.size):
            cs[q] = 0.0
        if before:
            for r in range(2, min(ny - 2, RU) + 1):
                _column_rows(cs, 1, v, z - 1, r, -1, nx, sz, st, g)
        return
    r_in, r_out = _row(y - 1, ny), _row(y - 1 - R, ny)
    if r_in >= 0 or r_out >= 0:
        _column_rows(cs, 0, v, z, r_in, r_out, nx, sz, st, g)
    r_in, r_out = _row(y + RU, ny), _row(y - RU - 1, ny)
    if before and (r_in >= 0 or r_out >= 0):
        _column_rows(cs, 1, v, z - 1, r_in, r_out, nx, sz, st, g)


@kernel(inline=True)
def _move_columns(ws, cs, half, c_in, c_out, nx):
    """Add column ``c_in``'s sums of ``half`` to the window's, take away ``c_out``'s
    (either -1: none)."""
    b_in = (half * nx + c_in) * NQ
    b_out = (half * nx + c_out) * NQ
    if c_in >= 0 and c_out >= 0:
        for q in range(np.uint64(NQ)):
            ws[q] += cs[np.uint64(b_in) + q] - cs[np.uint64(b_out) + q]
    elif c_in >= 0:
        for q in range(np.uint64(NQ)):
            ws[q] += cs[np.uint64(b_in) + q]
    elif c_out >= 0:
        for q in range(np.uint64(NQ)):
            ws[q] -= cs[np.uint64(b_out) + q]


@kernel(inline=True)
def _column(c, nx):
    """Column ``c`` if training voxels lie on it, else -1."""
    return c if 2 <= c <= nx - 2 else -1


@kernel(nrt=False)
def advance(cs, ws, v, i, x, nx, st, g):
    """Move the window's sums to voxel ``i`` at column ``x`` (``2 <= x <= nx - 2``, on a
    row :func:`row_start` has moved to; called for every such voxel in order, coded or
    not, after the voxel before is known)."""
    if x == 2:
        for q in range(NQ):
            ws[q] = 0.0
        for c in range(2, min(nx - 2, 2 + R) + 1):
            _move_columns(ws, cs, 0, c, -1, nx)
        for c in range(2, min(nx - 2, 2 + RU) + 1):
            _move_columns(ws, cs, 1, c, -1, nx)
        return
    _move_columns(ws, cs, 0, _column(x + R, nx), _column(x - R - 1, nx), nx)
    _move_columns(ws, cs, 1, _column(x + RU, nx), _column(x - RU - 1, nx), nx)
    _exchange(ws, 0, v, i - 1, i - R - 1 if x - R - 1 >= 2 else -1, st, g)


@kernel(nrt=False)
def solve(ws, a):
    """Fit the weights to the window's sums (:func:`advance`) into ``a[W_AT:]``; False
    (no weights) with fewer than ``MIN_SAMPLES`` training voxels, training voxels all of
    one value, or a system that is not positive definite in floating point."""
    n = np.int64(ws[N_AT])
    t = np.int64(ws[T_AT])
    if n < MIN_SAMPLES or n * np.int64(ws[TT_AT]) == t * t:  # (int64: n t^2 passes 2^53)
        return False
    # The system's upper triangle into a[j * NF + k] (k >= j), its right-hand side (the
    # products with the target) into a[W_AT + j].
    q = 0
    tr = 0.0
    for j in range(NF):
        for k in range(j, NF):
            a[j * NF + k] = ws[q]
            q += 1
        a[W_AT + j] = ws[q]
        q += 1
        tr += a[j * NF + j]
    ridge = RIDGE * tr / NF + 1e-9
    for j in range(NF):
        a[j * NF + j] += ridge
    # A = U'U, row by row into the upper triangle, and U' y = b alongside; each loop
    # updates independent entries (no sum is reordered), so it vectorises as written.
    for j in range(NF):
        d = a[j * NF + j]
        if not d > 0.0:
            return False
        d = np.sqrt(d)
        a[j * NF + j] = d
        for k in range(j + 1, NF):
            a[j * NF + k] /= d
        y = a[W_AT + j] / d
        a[W_AT + j] = y
        for r in range(j + 1, NF):
            u = a[j * NF + r]
            for k in range(r, NF):
                a[r * NF + k] -= u * a[j * NF + k]
            a[W_AT + r] -= y * u
    # U w = y, from the last weight back.
    for j in range(NF - 1, -1, -1):
        t = a[W_AT + j]
        for k in range(j + 1, NF):
            t -= a[j * NF + k] * a[W_AT + k]
        a[W_AT + j] = t / a[j * NF + j]
    return True


@kernel(inline=True)
def estimate(a, v, i, st):
    """The estimate of voxel ``i`` in eighths by the weights :func:`solve` left in ``a``
    (``NONE`` if they are not finite or it is out of range)."""
    p = a[W_AT + NF - 1]
    for k in range(NF - 1):
        p += a[W_AT + k] * np.float64(v[np.uint64(i - st[k])])
    p = 8.0 * p + 0.5
    if not abs(p) < 4.0e15:  # (NaN too)
        return NONE
    return np.int64(np.floor(p))


@kernel(inline=True)
def refits(x):
    """Whether the weights are fitted at column ``x`` (else those of ``x - 1`` serve)."""
    return (x & 1) == 0


@kernel(nrt=False)
def _estimates_kernel(v, shape, st, cs, ws, a, g, out):
    nz, ny, nx = shape[0], shape[1], shape[2]
    for z in range(2, nz):
        for y in range(ny):
            row_start(cs, v, z, y, ny, nx, st, g)
            if y < 2 or y > ny - 2:
                continue
            fitted = False
            for x in range(2, nx - 1):
                i = (z * ny + y) * nx + x
                advance(cs, ws, v, i, x, nx, st, g)
                if refits(x):
                    fitted = solve(ws, a)
                if fitted:
                    out[np.uint64(i)] = estimate(a, v, i, st)


def estimates(values: np.ndarray, offsets) -> np.ndarray:
    """Every voxel's estimate (in eighths, ``NONE`` where there is none) from the
    neighbours at ``offsets`` of the 3-D integer array ``values`` (from 0, below
    ``2^MAX_BITS``): what a coder computes voxel by voxel, all at once."""
    v = np.ascontiguousarray(values, dtype=np.int64)
    out = np.full(v.size, NONE, dtype=np.int64)
    if usable(v.shape, int(v.max(initial=0))):
        _estimates_kernel(
            v.reshape(-1), np.array(v.shape, dtype=np.int64), steps(offsets, v.shape),
            *workspace(v.shape), out,
        )  # fmt: skip
    return out.reshape(v.shape)
