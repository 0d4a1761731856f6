"""The quantised voxels predicted by a long least-squares predictor, the residual coded
by the lossless codec (the bounded codec's flag ``residuals`` alone; formats/lossy-1.md
steps 20 and 21).

On a field sampled finer than its content (a spectral simulation's velocity, de-aliased
to 2/3 of the grid's wavenumbers; climate fields along latitude and longitude), a voxel
is predictable from far along each axis: a linear predictor over the 62 causal
neighbours within two voxels and the next ones back along each axis, fitted per brick by
least squares on the quantised voxels (which the decoder has: closed-loop prediction on
the decoded values), leaves a residual 2-3x smaller than 16 neighbours do on the
Taylor-Green velocity (scripts/lossy17_predictor_entropy.py). Weights are fixed point
(2^-16), sums exact integers: encoder and decoder compute the same on any machine.

Version 1 (lossy17, step 20): one reach ``K`` on every axis, one fit where the whole
neighbourhood exists, one for the 62 near neighbours, a Lorenzo predictor nearer the
faces. Version 2 (step 21, first byte 0): a reach per axis (``Kz`` 2 on thin or
anisotropic fields), and the voxels near the faces, whose neighbourhood is cut, sorted
into classes by how much of it is left on each axis, each class with its own fit (half a
64^3 brick lies within 12 voxels of a face it predicts from). Its residual may also be
coded in contexts of the residual's own magnitudes: by the adaptive binary coder (type 3,
step 22) or by static rANS tables (type 4, step 23, as fast to decode as the wavelet).
"""

from __future__ import annotations

import functools
import itertools
import struct

import numpy as np

from .._jit import kernel
from ..entropy import rans
from ..entropy.common import encode_with_retry, stream_bytes
from ..entropy.rangecoder import end_status, finish_stream, open_encoder, open_stream
from ..errors import FormatError
from ..format.deflate import deflate, inflate
from ..format.sections import put_section, take_section
from . import fastpredict as fp
from .predict import NO_RESIDUAL, activity_class
from .predictfit import MODEL_INIT, N_MODELS, get_residual, put_residual

FB = 16  # fixed-point bits of the weights
W_LIMIT = 1 << 20  # |weight| < 16
K_TRIED = (4, 8, 12)  # axis reaches the encoder tries, each at most a quarter of the axis
K_THIN = 2  # and along z, the near neighbours alone (thin or anisotropic fields)
K_MAX = 16
_DTYPES = (np.uint8, np.uint16, np.uint32)
_HEAD = struct.Struct("<BBq")  # version 1: K, residual dtype code, residual offset
_HEAD2 = struct.Struct("<BBBBBq")  # version 2: 0, Kz, Ky, Kx, residual dtype code, offset
# Version 2's residual code past the dtypes (step 22): the residual itself, signed, by the
# adaptive binary coder in contexts of the causal residuals' magnitudes (offset 0).
CONTEXT_CODED = len(_DTYPES)
# A face class is fitted where it holds this many voxels a weight (fewer: Lorenzo; its
# weights would cost more than they save), and keeps its weights where the residual's
# estimated bits they save (against Lorenzo on the same voxels) pay WEIGHT_BITS each.
MIN_VOXELS_PER_WEIGHT = 8
WEIGHT_BITS = 20  # a weight's bytes in the zstd frame: 2.2-2.3 on the fields measured
# The off-row sums run in float64 (vectorised) where no partial sum can pass 2^53
# (exact integers), else in int64.
_EXACT_FLOAT = float(1 << 53)
_U = np.uint64  # numba tests signed indices for a wrap-around, which stops vectorising


@functools.lru_cache(maxsize=1)
def near_offsets() -> tuple:
    """Every causal (dz, dy, dx) step back within two voxels (62)."""
    out = []
    for dz in range(3):
        for dy in range(-2, 3):
            for dx in range(-2, 3):
                if dz == 0 and (dy < 0 or (dy == 0 and dx <= 0)):
                    continue
                out.append((dz, dy, dx))
    return tuple(out)


def long_offsets(k: int) -> tuple:
    """:func:`near_offsets` and the steps 3..k back along each axis (version 1)."""
    return class_offsets((k, 2), (k, 2), (k, 2))


@functools.lru_cache(maxsize=4096)  # a decoder meets the same classes brick after brick
def class_offsets(z: tuple, y: tuple, x: tuple) -> tuple:
    """The steps of a class whose neighbourhood reaches ``(back, ahead)`` voxels along
    each axis: the near steps inside it, then 3..back along x, y, z."""
    (bz, _), (by, ay), (bx, ax) = z, y, x
    near = [
        (dz, dy, dx) for dz, dy, dx in near_offsets()
        if dz <= bz and -ay <= dy <= by and -ax <= dx <= bx
    ]  # fmt: skip
    ext = [(0, 0, d) for d in range(3, bx + 1)] + [(0, d, 0) for d in range(3, by + 1)]
    return tuple(near + ext + [(d, 0, 0) for d in range(3, bz + 1)])


@functools.lru_cache(maxsize=64)
def grades(k: int) -> tuple:
    """How far back a face class may reach along an axis of reach ``k``."""
    return tuple(sorted({0, 1, 2, k} | {g for g in (4, 8, 12) if g < k}))


def axis_states(n: int, k: int, ahead: bool) -> np.ndarray:
    """Per position along an axis of length ``n``: ``3 * (index of the largest grade
    within reach back) + (voxels ahead, at most 2)`` (ahead always 2 along z)."""
    g = np.array(grades(k))
    p = np.arange(n)
    back = np.searchsorted(g, np.minimum(p, k), side="right") - 1
    a = np.minimum(n - 1 - p, 2) if ahead else np.full(n, 2)
    return (3 * back + a).astype(np.int64)


@functools.lru_cache(maxsize=64)
def _classes(shape: tuple, reach: tuple) -> tuple:
    """What a version-2 plan of ``shape`` and ``reach`` holds before its weights (a
    decoder meets the same shape brick after brick): the per-axis states, the states
    used, each class's steps, and every class's steps stacked (:func:`_stacked`)."""
    states = [axis_states(n, k, a) for n, k, a in zip(shape, reach, (False, True, True))]
    used = [np.unique(s).tolist() for s in states]
    keys = [
        tuple((grades(k)[s // 3], s % 3) for k, s in zip(reach, t))
        for t in itertools.product(*used)
    ]
    offsets = [class_offsets(*key) for key in keys]
    return states, used, offsets, _stacked(offsets)


def _stacked(offsets) -> tuple:
    """Every class's steps stacked ``(n, 3)`` in class order, and the class of each."""
    counts = [len(o) for o in offsets]
    steps = np.array([s for o in offsets for s in o], np.int64).reshape(-1, 3)
    return steps, np.repeat(np.arange(len(offsets)), counts)


class Plan:
    """The classes of a brick of ``shape`` at reach ``(kz, ky, kx)`` (version 2), or of a
    version-1 brick: per-axis states, the class of each state triple (-1: Lorenzo), the
    steps of each class."""

    def __init__(self, shape, reach, v1: bool = False):
        self.shape = tuple(int(n) for n in shape)
        self.reach = tuple(int(k) for k in reach)
        nz, ny, nx = self.shape
        if v1:
            k = self.reach[0]
            self.states = [_v1_states(n, k, a) for n, a in ((nz, False), (ny, True), (nx, True))]
            tab = np.full((3, 3, 3), -1, np.int64)
            for s in itertools.product(range(3), repeat=3):
                tab[s] = -1 if min(s) == 0 else (0 if min(s) == 2 else 1)
            self.table = tab
            self.offsets = [long_offsets(k), near_offsets()]
            self._stacked = _stacked(self.offsets)
            return
        # shared with other plans of this shape and reach: never written to
        self.states, self.used, self.offsets, self._stacked = _classes(self.shape, self.reach)
        self.table = None  # set by :meth:`keep`

    def boxes(self) -> list:
        """Per class, the ``(first, end)`` indices of its voxels along each axis (the
        encoder's fits)."""
        ends = [{v: (int(np.argmax(st == v)), int(st.size - np.argmax(st[::-1] == v)))
                 for v in used} for st, used in zip(self.states, self.used)]  # fmt: skip
        return [[e[v] for e, v in zip(ends, t)] for t in itertools.product(*self.used)]

    def keep(self, present) -> None:
        """The classes with weights (the rest: Lorenzo)."""
        self.present = np.asarray(present, bool)
        tab = np.full(tuple(int(s.max()) + 1 for s in self.states), -1, np.int64)
        grid = [g.reshape(-1) for g in np.meshgrid(*self.used, indexing="ij")]  # class order
        tab[tuple(g[self.present] for g in grid)] = np.flatnonzero(self.present)
        self.table = tab

    def kernel_args(self, weights, qmax):
        """The walk's arrays: per class its off-row steps (flat) and in-row steps (dx)
        with their weights, and whether its sums may run in float64 (every class's
        steps at once, the classes without weights left out)."""
        nz, ny, nx = self.shape
        nc = len(self.offsets)
        present = np.array([w is not None and len(o) > 0 for w, o in zip(weights, self.offsets)])
        w = np.concatenate(
            [np.zeros(0, np.int64)]
            + [np.asarray(v, np.int64) for v, p in zip(weights, present) if p]
        )  # fmt: skip
        steps, cls = self._stacked
        take = present[cls]
        st, cls = steps[take], cls[take]  # the order of w
        row = (st[:, 0] == 0) & (st[:, 1] == 0)
        off = ~row

        def starts(mask):
            return np.concatenate([[0], np.cumsum(np.bincount(cls[mask], minlength=nc))])

        xb = np.flatnonzero(np.diff(self.states[2])) + 1
        fl = np.bincount(cls, weights=np.abs(w), minlength=nc) * float(qmax) < _EXACT_FLOAT
        return (
            self.states[0], self.states[1], self.states[2],
            np.array([0, *xb.tolist(), nx], np.int64), self.table.astype(np.int64),
            starts(off).astype(np.int64), st[off] @ np.array([ny * nx, nx, 1], np.int64),
            w[off], starts(row).astype(np.int64), st[row, 2], w[row], fl.astype(np.bool_),
        )  # fmt: skip


def _v1_states(n: int, k: int, ahead: bool) -> np.ndarray:
    """Version 1 along an axis: 0 Lorenzo, 1 the near set's box, 2 the long set's."""
    p = np.arange(n)
    ok = (p + 2 < n) if ahead else np.ones(n, bool)
    return np.where(~ok | (p < 2), 0, np.where(p >= k, 2, 1)).astype(np.int64)


@kernel(inline=True)
def _lorenzo(q, i, z, y, x, sy, sz):
    """The Lorenzo predictor of the neighbours that exist (0 at the first voxel)."""
    p = np.int64(0)
    if z > 0 and y > 0 and x > 0:
        p = (q[i - 1] + q[i - sy] + q[i - sz] - q[i - sy - 1] - q[i - sz - 1] - q[i - sz - sy]
             + q[i - sz - sy - 1])  # fmt: skip
    elif y > 0 and x > 0:
        p = q[i - 1] + q[i - sy] - q[i - sy - 1]
    elif z > 0 and x > 0:
        p = q[i - 1] + q[i - sz] - q[i - sz - 1]
    elif z > 0 and y > 0:
        p = q[i - sy] + q[i - sz] - q[i - sz - sy]
    elif x > 0:
        p = q[i - 1]
    elif y > 0:
        p = q[i - sy]
    elif z > 0:
        p = q[i - sz]
    return p


@kernel(inline=True)
def _row_sums(q, qf, row, c, x0, x1, s_off, o_off, w_off, fl, acc, acci):
    """Into ``acci[x0:x1]``: the sums over class ``c``'s steps in other rows (decoded
    already) for the run ``x0..x1`` of the row starting at voxel ``row``. In float64
    where the class's sums are exact integers (``fl``: every partial sum under 2^53, so
    any order gives the same), four steps a pass over the run (a quarter of the loads
    and stores of ``acc``); else in int64, a step a pass."""
    k = s_off[c]
    k1 = s_off[c + 1]
    if fl[c]:
        for x in range(x0, x1):
            acc[x] = 0.0
        while k + 4 <= k1:
            w0, w1 = np.float64(w_off[k]), np.float64(w_off[k + 1])
            w2, w3 = np.float64(w_off[k + 2]), np.float64(w_off[k + 3])
            b0, b1 = row - o_off[k], row - o_off[k + 1]  # >= 0: the steps exist
            b2, b3 = row - o_off[k + 2], row - o_off[k + 3]
            for x in range(x0, x1):  # unsigned indices: vectorised
                acc[_U(x)] += (w0 * qf[_U(b0 + x)] + w1 * qf[_U(b1 + x)]) + (
                    w2 * qf[_U(b2 + x)] + w3 * qf[_U(b3 + x)]
                )
            k += 4
        while k < k1:
            wk = np.float64(w_off[k])
            b = row - o_off[k]
            for x in range(x0, x1):
                acc[_U(x)] += wk * qf[_U(b + x)]
            k += 1
        for x in range(x0, x1):
            acci[x] = np.int64(acc[x])
    else:
        for x in range(x0, x1):
            acci[x] = 0
        for j in range(k, k1):
            wk = w_off[j]
            b = row - o_off[j]
            for x in range(x0, x1):
                acci[_U(x)] += wk * q[_U(b + x)]


@kernel(nrt=False)
def _walk(q, qf, r, zs, ys, xs, xb, table, s_off, o_off, w_off, s_in, o_in, w_in, fl,
          nz, ny, nx, acc, acci):  # fmt: skip
    """Residuals ``r = q - prediction`` in C order, row by row: on a run of a row in one
    class, the sums over the steps in other rows first, for the whole run
    (:func:`_row_sums`; ``qf`` is ``q`` as float64), then the steps back along the row
    voxel by voxel. ``acc`` and ``acci`` (``nx``) are scratch."""
    sy = nx
    sz = ny * nx
    half = np.int64(1) << (FB - 1)
    for z in range(nz):
        for y in range(ny):
            row = z * sz + y * sy
            for seg in range(xb.size - 1):
                x0 = xb[seg]
                x1 = xb[seg + 1]
                c = table[zs[z], ys[y], xs[x0]]
                if c >= 0:
                    _row_sums(q, qf, row, c, x0, x1, s_off, o_off, w_off, fl, acc, acci)
                for x in range(x0, x1):
                    i = row + x
                    if c >= 0:
                        s = acci[x]
                        for k in range(s_in[c], s_in[c + 1]):
                            s += w_in[k] * q[i - o_in[k]]
                        p = (s + half) >> FB
                    else:
                        p = _lorenzo(q, i, z, y, x, sy, sz)
                    r[i] = q[i] - p
    return -1


@kernel(nrt=False)
def _unwalk(q, qf, r, zs, ys, xs, xb, table, s_off, o_off, w_off, s_in, o_in, w_in, fl,
            nz, ny, nx, qmax, acc, acci, wrow):  # fmt: skip
    """:func:`_walk` backwards: ``q = r + prediction``, ``qf`` filled as it goes (``q``
    may be ``r``: voxel ``i``'s residual is read once, before ``q[i]`` is written). Along
    the row, the step one voxel back (decoded last) is added last, from a register, so
    the other steps' sum does not wait for it; those steps (2..d back) are weighed as one
    dense run (``wrow``, scratch of :data:`K_MAX`; zeros for steps the class lacks), a
    loop over adjacent voxels that vectorises. Integer sums: any order, the same result.
    Returns the first voxel decoded outside ``[0, qmax]`` or -1."""
    sy = nx
    sz = ny * nx
    half = np.int64(1) << (FB - 1)
    for z in range(nz):
        for y in range(ny):
            row = z * sz + y * sy
            for seg in range(xb.size - 1):
                x0 = xb[seg]
                x1 = xb[seg + 1]
                c = table[zs[z], ys[y], xs[x0]]
                if c < 0:
                    for x in range(x0, x1):
                        i = row + x
                        v = r[i] + _lorenzo(q, i, z, y, x, sy, sz)
                        if v < 0 or v > qmax:
                            return i
                        q[i] = v
                        qf[i] = np.float64(v)
                    continue
                _row_sums(q, qf, row, c, x0, x1, s_off, o_off, w_off, fl, acc, acci)
                w1 = np.int64(0)
                nd = 0  # wrow[j] weighs the voxel nd + 1 - j back
                for k in range(s_in[c], s_in[c + 1]):
                    nd = max(nd, o_in[k] - 1)
                for j in range(nd):
                    wrow[j] = 0
                for k in range(s_in[c], s_in[c + 1]):
                    if o_in[k] == 1:
                        w1 += w_in[k]
                    else:
                        wrow[nd + 1 - o_in[k]] += w_in[k]
                prev = q[row + x0 - 1] if x0 > 0 else np.int64(0)
                for x in range(x0, x1):
                    i = row + x
                    s = acci[_U(x)]
                    b = i - nd - 1  # >= 0 where a step reaches nd + 1 back
                    for j in range(nd):
                        s += wrow[_U(j)] * q[_U(b + j)]
                    v = r[_U(i)] + ((s + w1 * prev + half) >> FB)
                    if v < 0 or v > qmax:
                        return i
                    q[_U(i)] = v
                    qf[_U(i)] = np.float64(v)
                    prev = v
    return -1


def walk(q: np.ndarray, r: np.ndarray, plan: Plan, weights, qmax: int, decode: bool) -> int:
    """:func:`_walk` (residuals into ``r``) or :func:`_unwalk` (``decode``: voxels into
    ``q``) over flat int64 ``q`` and ``r`` of ``plan``'s shape."""
    qf = np.empty(q.size, np.float64) if decode else q.astype(np.float64)
    nz, ny, nx = plan.shape
    args = plan.kernel_args(weights, qmax)
    acc, acci = np.empty(nx, np.float64), np.empty(nx, np.int64)
    if decode:
        wrow = np.empty(K_MAX, np.int64)
        return int(_unwalk(q, qf, r, *args, nz, ny, nx, np.int64(qmax), acc, acci, wrow))
    return int(_walk(q, qf, r, *args, nz, ny, nx, acc, acci))


def _fit(q: np.ndarray, offs, box, ata_out=None) -> np.ndarray | None:
    """Fixed-point least-squares weights of ``offs`` over the voxels of ``box``
    (``[(z0, z1), (y0, y1), (x0, x1)]``, where every step exists), every other row and
    column of large boxes (normal equations summed slab by slab; a quarter of the work,
    the same bytes within 0.1 % on the Taylor-Green fields); None where too few voxels."""
    (z0, z1), (y0, y1), (x0, x1) = box
    n = len(offs)
    count = (z1 - z0) * (y1 - y0) * (x1 - x0)
    if n == 0 or count < 4 * n:
        return None
    s = 2 if count >= 64 * n and min(y1 - y0, x1 - x0) > 1 else 1
    ata, aty, _ = _normal(q, offs, box, s)
    w = _solve(ata, aty)
    if w is None:
        return None
    return np.clip(np.rint(w * (1 << FB)), -W_LIMIT, W_LIMIT).astype(np.int64)


_SLAB_CHUNK = 1 << 20  # float64 elements of A gathered at once (8 MB)


def _normal(q, offs, box, s):
    """(A^T A, A^T y, y^T y) of ``offs`` over ``box`` at stride ``s`` along y and x.

    Summed slab by slab along z in order, each slab's products by BLAS on an (m, n)
    C-ordered A as ever (the bytes of the fitted weights depend on the summation
    order); the slabs' A and y gathered by :func:`_gather` a chunk at a time and their
    products taken by one stacked matmul (the same BLAS call per slab), not a Python
    stack of slices per slab (22 % of a profile of the default encoder, session 35)."""
    (z0, z1), (y0, y1), (x0, x1) = box
    n = len(offs)
    m = len(range(y0, y1, s)) * len(range(x0, x1, s))
    ata = np.zeros((n, n))
    aty = np.zeros(n)
    yty = 0.0
    if n == 0 or m == 0 or z1 <= z0:
        return ata, aty, yty
    q = np.ascontiguousarray(q, dtype=np.int64)
    steps = np.array(offs, dtype=np.int64).reshape(n, 3)
    per = max(1, _SLAB_CHUNK // (m * (n + 1)))
    for c0 in range(z0, z1, per):
        c1 = min(z1, c0 + per)
        a = np.empty((c1 - c0, m, n))
        t = np.empty((c1 - c0, m))
        _gather(q, steps, c0, c1, y0, y1, x0, x1, s, a, t)
        at = a.transpose(0, 2, 1)
        g = at @ a
        b = np.matmul(at, t[:, :, None])
        tt = np.matmul(t[:, None, :], t[:, :, None])
        for i in range(c1 - c0):
            ata += g[i]
            aty += b[i, :, 0]
            yty += float(tt[i, 0, 0])
    return ata, aty, yty


@kernel(nrt=False)
def _gather(q, steps, z0, z1, y0, y1, x0, x1, s, a, t):
    """Slabs ``z0:z1`` of :func:`_normal`'s A (``a[z - z0, p, k]``: the voxel at step
    ``steps[k]`` back from the p-th voxel of the slab at stride ``s``, as float64) and
    y (``t``), every voxel in C order of (y, x)."""
    n = steps.shape[0]
    for z in range(z0, z1):
        p = 0
        for y in range(y0, y1, s):
            for x in range(x0, x1, s):
                for k in range(n):
                    a[z - z0, p, k] = np.float64(q[z - steps[k, 0], y - steps[k, 1], x - steps[k, 2]])
                t[z - z0, p] = np.float64(q[z, y, x])
                p += 1


def _solve(ata, aty):
    """Least-squares weights under a ridge, raised until every weight fits the fixed
    point's range (far steps along a smooth axis are nearly collinear: clipped weights
    of an unstable fit cost 40 % of the bytes on climate_rh at 1e-5 of its range)."""
    n = len(aty)
    for ridge in (1e-9, 1e-7, 1e-5, 1e-3, 1e-1):
        try:
            w = np.linalg.solve(ata + ridge * np.trace(ata) / n * np.eye(n), aty)
        except np.linalg.LinAlgError:
            continue
        if np.abs(w).max(initial=0) * (1 << FB) < W_LIMIT:
            return w
    return None


def reach_choices(shape) -> list[tuple[int, int, int]]:
    """Every reach the encoder may use on a brick of ``shape``: per axis 4, 8, 12 up to
    a quarter of its length (2 where none fits), and 2 along z."""
    per = []
    for a, n in enumerate(shape):
        ks = [k for k in K_TRIED if k <= n // 4] or [K_THIN]
        if a == 0 and K_THIN not in ks:
            ks = [K_THIN, *ks]
        per.append(ks)
    return list(itertools.product(*per))


def rank_reaches(q: np.ndarray) -> list[tuple[int, int, int]]:
    """The reaches of :func:`reach_choices`, best first by the squared residual of the
    fit of their full neighbourhood, over one sample (where the largest exists, every
    other row and column): one set of normal equations, a solve per reach."""
    choices = reach_choices(q.shape)
    top = [max(c[a] for c in choices) for a in range(3)]
    union = class_offsets((top[0], 2), (top[1], 2), (top[2], 2))
    nz, ny, nx = q.shape
    box = [(top[0], nz), (top[1], ny - 2), (top[2], nx - 2)]
    if min(b - a for a, b in box) <= 0 or np.prod([b - a for a, b in box]) < 16 * len(union):
        return choices
    ata, aty, yty = _normal(q, union, box, 2)
    index = {o: i for i, o in enumerate(union)}
    scored = []
    for c in choices:
        sel = [index[o] for o in class_offsets((c[0], 2), (c[1], 2), (c[2], 2))]
        w = _solve(ata[np.ix_(sel, sel)], aty[sel])
        a, b = ata[np.ix_(sel, sel)], aty[sel]
        rss = np.inf if w is None else yty - 2 * float(w @ b) + float(w @ a @ w)
        scored.append((rss, c))
    return [c for _, c in sorted(scored)]


def tried_reaches(q: np.ndarray) -> list[tuple[int, int, int]]:
    """The reaches the encoder codes: the two best of :func:`rank_reaches`, and the
    shortest (least steps) where it is not one of them. The ranking sees the interior
    alone; on a field that is not band-limited, a long reach's larger faces and weights
    cost more than its fit saves there (tgv_vorticity at 1e-3 of the range: reach 12
    ranked first, 191.6 kB coded; reach (2, 4, 4) 186.9 kB)."""
    ranked = rank_reaches(q)
    short = min(reach_choices(q.shape), key=sum)
    return ranked[:2] + ([short] if short not in ranked[:2] else [])


def fit(q: np.ndarray, reach) -> tuple[Plan, list]:
    """The version-2 plan at ``reach`` and each class's weights (None: Lorenzo)."""
    plan = Plan(q.shape, reach)
    weights = []
    for offs, box in zip(plan.offsets, plan.boxes()):
        count = int(np.prod([b - a for a, b in box]))
        ok = offs and count >= MIN_VOXELS_PER_WEIGHT * len(offs)
        weights.append(_fit(q, offs, box) if ok else None)
    plan.keep([w is not None for w in weights])
    return plan, weights


def residuals(q: np.ndarray, reach, qmax: int | None = None, prune: bool = False):
    """(residuals (int64, the brick's shape), plan, weights) of a version-2 fit at
    ``reach`` (an int: the same on every axis); with ``prune``, the classes whose
    weights do not pay for themselves (:func:`_prune`) left to Lorenzo."""
    if isinstance(reach, int):
        reach = (reach, reach, reach)
    q = np.ascontiguousarray(q, dtype=np.int64)
    plan, weights = fit(q, reach)
    r = np.empty_like(q)
    top = int(q.max(initial=0)) if qmax is None else qmax
    walk(q.reshape(-1), r.reshape(-1), plan, weights, top, False)
    if prune:
        r, weights = _prune(q, plan, weights, r, top)
    return r, plan, weights


def _prune(q, plan, weights, r, top):
    """Each fitted class against Lorenzo on its own voxels (classes do not interact: a
    prediction reads ``q``): its weights are kept where the residual's bits they save,
    estimated as a Laplacian's, ``n log2(mean |r| Lorenzo / mean |r| fitted)``, pass
    WEIGHT_BITS a weight (fewer classes, a shorter header: tas_monthly at 1e-5 of the
    range codes 0.3 % shorter)."""
    fitted = plan.present.copy()
    cls = plan.table[np.ix_(*plan.states)].reshape(-1)  # every voxel's class (-1 Lorenzo)
    plan.keep(np.zeros_like(fitted))
    lor = np.empty_like(q)
    walk(q.reshape(-1), lor.reshape(-1), plan, weights, top, False)
    m = cls >= 0
    n = np.bincount(cls[m], minlength=fitted.size)
    a_fit = np.bincount(cls[m], np.abs(r.reshape(-1)[m]).astype(np.float64), fitted.size)
    a_lor = np.bincount(cls[m], np.abs(lor.reshape(-1)[m]).astype(np.float64), fitted.size)
    gain = n * np.log2((a_lor + n + 1.0) / (a_fit + n + 1.0))
    size = np.array([0 if w is None else len(w) for w in weights])
    keep = fitted & (gain > WEIGHT_BITS * size)
    plan.keep(keep)
    out = np.where(keep[np.maximum(cls, 0)] & m, r.reshape(-1), lor.reshape(-1))
    return out.reshape(q.shape), [w if k else None for w, k in zip(weights, keep)]


def residuals_v1(q: np.ndarray, k: int):
    """(residuals, long weights, near weights) of version 1 (lossy17's encoder: one
    reach, two fits), kept to test its decoder."""
    q = np.ascontiguousarray(q, dtype=np.int64)
    plan = Plan(q.shape, (k, k, k), v1=True)
    nz, ny, nx = q.shape
    w = []
    for offs in plan.offsets:
        b = _box(offs)
        fitted = _fit(q, offs, [(b[0], nz), (b[1], ny - b[2]), (b[3], nx - b[4])])
        w.append(np.zeros(len(offs), np.int64) if fitted is None else fitted)
    r = np.empty_like(q)
    walk(q.reshape(-1), r.reshape(-1), plan, w, int(q.max(initial=0)), False)
    return r, w[0], w[1]


def _box(offs) -> list:
    o = np.array(offs)
    return [int(o[:, 0].max()), int(o[:, 1].max()), max(0, -int(o[:, 1].min())),
            int(o[:, 2].max()), max(0, -int(o[:, 2].min()))]  # fmt: skip


def estimate_bits(r: np.ndarray) -> float:
    """Zeroth-order entropy of the residuals, bits in all (the encoder's gate; the
    lossless codec's activity contexts code 0-15 % below it)."""
    _, n = np.unique(r, return_counts=True)
    p = n / r.size
    return float(-(n * np.log2(p)).sum())


def _shifted(r: np.ndarray):
    """(residual type code, offset) of ``r`` shifted to start at 0; None past 32 bits."""
    lo = int(r.min())
    span = int(r.max()) - lo
    code = next((c for c, d in enumerate(_DTYPES) if span <= np.iinfo(d).max), None)
    return None if code is None else (code, lo)


# The causal residuals whose magnitudes make a voxel's context: (dz, dy, dx, weight),
# the three face neighbours twice. On the long fit's residual of tgv_pressure at 1e-5 of
# the range: 3 steps 307.9 kB, these 12 305.3 kB, the lossless wavelet 312.7 kB
# (results/lossy/lossy19/ctx_code*.txt).
_ACT = np.array([(0, 0, 1, 2), (0, 1, 0, 2), (1, 0, 0, 2), (0, 1, 1, 1), (0, 1, -1, 1),
                 (0, 0, 2, 1), (0, 2, 0, 1), (1, 1, 0, 1), (1, 0, 1, 1), (1, -1, 0, 1),
                 (1, 0, -1, 1), (2, 0, 0, 1)], np.int64)  # fmt: skip
_ACT_CAP = np.int64(1) << 40  # a magnitude counts at most this much (damaged streams)


@kernel(inline=True)
def _mag(v):
    return min(abs(v), _ACT_CAP)


@kernel(inline=True)
def _activity(r, i, z, y, x, ny, nx):
    """The activity class of voxel ``i``: the class of the weighted sum of the causal
    residuals' magnitudes (:data:`_ACT`), scaled by 16 over the weight of the steps
    inside the brick (the faces' sums are not taken for calm ones: -0.2 %)."""
    sy = nx
    sz = ny * nx
    if z >= 2 and y >= 2 and y + 1 < ny and x >= 2 and x + 1 < nx:  # every step inside
        a = 2 * (_mag(r[i - 1]) + _mag(r[i - sy]) + _mag(r[i - sz]))
        a += _mag(r[i - sy - 1]) + _mag(r[i - sy + 1]) + _mag(r[i - 2]) + _mag(r[i - 2 * sy])
        u = i - sz
        a += _mag(r[u - sy]) + _mag(r[u - 1]) + _mag(r[u + sy]) + _mag(r[u + 1])
        a = (16 * (a + _mag(r[i - 2 * sz]))) // 15  # (the weights' sum)
    else:
        a = np.int64(0)
        ws = np.int64(0)
        for k in range(_ACT.shape[0]):
            dz, dy, dx = _ACT[k, 0], _ACT[k, 1], _ACT[k, 2]
            if dz <= z and 0 <= y - dy < ny and 0 <= x - dx < nx:
                a += _ACT[k, 3] * _mag(r[i - dz * sz - dy * sy - dx])
                ws += _ACT[k, 3]
        if ws > 0:
            a = (16 * a) // ws
    return activity_class(a)


@kernel(inline=True)
def _sign_context(r, i, z, y, x, ny, nx):
    """Whether the residual before voxel ``i`` along x, and the sum of those before it
    along y and z, are positive: a sign context of 0..3 (-0.2 to -0.8 % against none)."""
    s = np.int64(0)
    if x > 0 and r[i - 1] > 0:
        s = np.int64(1)
    t = np.int64(0)
    if y > 0:
        t += min(max(r[i - nx], -_ACT_CAP), _ACT_CAP)
    if z > 0:
        t += min(max(r[i - ny * nx], -_ACT_CAP), _ACT_CAP)
    return s + (2 if t > 0 else 0)


@kernel(inline=True)
def _context(r, i, z, y, x, ny, nx):
    """``(activity class, sign context)`` of voxel ``i``."""
    return _activity(r, i, z, y, x, ny, nx), _sign_context(r, i, z, y, x, ny, nx)


@kernel(nrt=False)
def _put_residuals(r, nz, ny, nx, models, out):
    """The residuals ``r`` (flat, C order) by :func:`.predictfit.put_residual` in the
    contexts of :func:`_context`; the byte count, or -1 when ``out`` is too small."""
    low, rng, pos = open_encoder(out)
    cap = out.size
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                c, s = _context(r, i, z, y, x, ny, nx)
                low, rng, pos = put_residual(out, models, c, s, -1, r[i], low, rng, pos)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _get_residuals(data, r, nz, ny, nx, models):
    """Decode :func:`_put_residuals`' stream into ``r``: 0, or the stream's status (2: an
    impossible residual)."""
    code, rng, pos = open_stream(data)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                c, s = _context(r, i, z, y, x, ny, nx)
                v, code, rng, pos = get_residual(data, models, c, s, -1, code, rng, pos)
                if v == NO_RESIDUAL:
                    return 2
                r[i] = v
                i += 1
    return end_status(data, code, pos)


def _models() -> np.ndarray:
    return np.full(N_MODELS, MODEL_INIT, np.uint32)


def code_residuals(r: np.ndarray) -> bytes:
    """The residual volume (int64, 3-D) by the adaptive coder (residual code
    :data:`CONTEXT_CODED`)."""
    nz, ny, nx = r.shape
    flat = np.ascontiguousarray(r, np.int64).reshape(-1)
    return encode_with_retry(
        lambda out: _put_residuals(flat, nz, ny, nx, _models(), out), r.size, (2, 20),
        coder="bounded long-fit residual",
    )  # fmt: skip


def decode_residuals(data, shape) -> np.ndarray:
    """:func:`code_residuals`' residuals, flat int64."""
    what = "bounded long-fit residual"
    buf = stream_bytes(data, what)
    r = np.empty(int(np.prod(shape)), np.int64)
    if _get_residuals(buf, r, *shape, _models()) != 0:
        raise FormatError(f"{what}: the adaptive stream is corrupt")
    return r


# Residual type 4 (step 23): type 3's contexts with static rANS tables. The magnitude as
# a token of the fast predictive coder (:mod:`.fastpredict`: 16 direct, then 4 a bit
# length and raw low bits) in its activity class (the top classes merged by the
# encoder), then a nonzero one's sign as a symbol in its sign context. One table look-up
# where type 3 makes about ten adaptive decisions: 0.2-0.3 % longer on the Taylor-Green
# fields and tas_monthly, decoded 2.1-2.5x faster (results/lossy/lossy20/decode_stages.txt).
STATIC_CODED = CONTEXT_CODED + 1
_M_LIMIT = np.int64(1) << 32  # magnitudes from here have no token
N_SIGN = 4  # sign contexts, their tables after the activity classes'


@kernel(nrt=False)
def _static_tokens(r, nz, ny, nx, toks, ctxs, counts, bits):
    """Every voxel's magnitude token in its activity class, and a nonzero one's sign
    (token 0 or 1) in context ``fastpredict.NCLASS + sign context`` (``toks``, ``ctxs``:
    room for two a voxel), the counts per (context, token) and the raw bits (``bits``,
    LSB first). Returns (raw bit count, symbols), the count -1 when ``bits`` is too
    small, -2 for a residual without a token."""
    acc = np.uint64(0)
    nacc = 0
    bpos = 0
    i = 0
    k = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                v = r[i]
                if v >= _M_LIMIT or v <= -_M_LIMIT:
                    return -2, k
                c, s = _context(r, i, z, y, x, ny, nx)
                bpos, acc, nacc = fp.emit(toks, ctxs, counts, k, c, abs(v), bits, bpos, acc,
                                           nacc)  # fmt: skip
                k += 1
                if v != 0:
                    bpos, acc, nacc = fp.emit(toks, ctxs, counts, k, fp.NCLASS + s,
                                               np.int64(v < 0), bits, bpos, acc, nacc)  # fmt: skip
                    k += 1
                if bpos < 0:
                    return -1, k
                i += 1
    if nacc > 0:
        bits[bpos] = np.uint8(acc & np.uint64(0xFF))
        bpos += 1
    return bpos * 8 - ((8 - nacc) & 7), k


# The activity sum's divisors (the weights of the steps inside the brick): a row's inside
# from z = 2 on, at z = 1 (no step two slices back) and at z = 0 (no step back along z).
_INNER_WS = (15, 14, 8)
_CLASS_TABLE = 2048  # activity sums looked up in a table below this


@kernel(inline=True)
def _inner_sums(r, i, nx, sy, sz, z, pre, sgn):
    """For the inside of the row starting at voxel ``i`` (``x`` in ``2..nx-2``, ``y``
    in ``2..ny-2``): the weighted magnitudes of the causal steps in rows decoded already
    (all but ``x - 1`` and ``x - 2``), those of slices that exist (``z``), into ``pre``;
    the sign context's part from ``y - 1`` and ``z - 1`` into ``sgn`` (0 or 2). The same
    terms as :func:`_activity` and :func:`_sign_context` (integer sums, any order)."""
    for x in range(2, nx - 1):
        j = i + x
        u = j - sz
        a = 2 * _mag(r[_U(j - sy)]) + _mag(r[_U(j - sy - 1)]) + _mag(r[_U(j - sy + 1)])
        a += _mag(r[_U(j - 2 * sy)])
        t = min(max(r[_U(j - sy)], -_ACT_CAP), _ACT_CAP)
        if z >= 1:
            a += 2 * _mag(r[_U(u)]) + _mag(r[_U(u - sy)]) + _mag(r[_U(u - 1)])
            a += _mag(r[_U(u + sy)]) + _mag(r[_U(u + 1)])
            t += min(max(r[_U(u)], -_ACT_CAP), _ACT_CAP)
        if z >= 2:
            a += _mag(r[_U(j - 2 * sz)])
        pre[_U(x)] = a
        sgn[_U(x)] = 2 if t > 0 else 0


@kernel(nrt=False)
def _get_static(data, words, nbits, syms, info, nctx, r, nz, ny, nx, tok, pre, sgn, cls):
    """Decode :func:`code_static`'s symbols into ``r``: 0, 1 (a stream that does not end
    where its lengths say) or 2 (a sign symbol past 1). ``data`` and ``words`` carry the
    zero padding that :func:`.fastpredict.take_symbol` reads past their ends; an unused
    context's slots give a magnitude past any voxel's range (the walk rejects it).

    ``pre``, ``sgn`` (int64, ``nx``) and ``cls`` (uint8, 3 x :data:`_CLASS_TABLE`) are
    scratch. The inside of a row (away from the faces along y and x) reads its context
    from the sums over the rows before (:func:`_inner_sums`, a pass of its own) plus the
    two voxels before it along the row, kept in registers, and its class from a table:
    the voxel before is on the decoding's critical path, the rest is not. The faces go
    through :func:`_activity` and :func:`_sign_context`, as the encoder does."""
    top = nctx - 1
    for k in range(3):  # the class of each small sum, per divisor
        for a in range(_CLASS_TABLE):
            cls[k, a] = min(activity_class((16 * a) // _INNER_WS[k]), top)
    x0, x1, pos = rans.open_states(data)
    reader = (np.uint64(0), np.int64(0), np.int64(0))
    bad = False
    sy = nx
    sz = ny * nx
    i = 0
    for z in range(nz):
        k = min(z, 2)
        tab = cls[2 - k]
        ws = _INNER_WS[2 - k]
        for y in range(ny):
            x = 0
            inner = y >= 2 and y + 1 < ny and nx >= 4
            if inner:
                _inner_sums(r, i, nx, sy, sz, z, pre, sgn)
            while x < nx:
                if inner and x == 2:
                    m1 = r[_U(i - 1)]
                    m2 = _mag(r[_U(i - 2)])
                    for x in range(2, nx - 1):
                        a = pre[_U(x)] + 2 * _mag(m1) + m2
                        if a < _CLASS_TABLE:
                            c = np.int64(tab[_U(a)])
                        else:
                            c = min(activity_class((16 * a) // ws), top)
                        m, pos, x0, x1, reader = fp.take_symbol(syms, info, c, data, pos, x0,
                                                                x1, words, reader, tok)  # fmt: skip
                        if m != 0:
                            c = nctx + sgn[_U(x)] + (1 if m1 > 0 else 0)
                            t, pos, x0, x1, reader = fp.take_symbol(syms, info, c, data, pos,
                                                                    x0, x1, words, reader, tok)  # fmt: skip
                            bad |= t > 1
                            m = -m if t else m
                        r[_U(i)] = m
                        m2 = _mag(m1)
                        m1 = m
                        i += 1
                    x = nx - 1
                c = min(_activity(r, i, z, y, x, ny, nx), top)
                m, pos, x0, x1, reader = fp.take_symbol(syms, info, c, data, pos, x0, x1, words,
                                                        reader, tok)  # fmt: skip
                if m != 0:
                    c = nctx + _sign_context(r, i, z, y, x, ny, nx)
                    t, pos, x0, x1, reader = fp.take_symbol(syms, info, c, data, pos, x0, x1,
                                                            words, reader, tok)  # fmt: skip
                    bad |= t > 1
                    m = -m if t else m
                r[i] = m
                i += 1
                x += 1
    if bad:
        return 2
    used = 32 * reader[2] - reader[1]
    if used > nbits or (used + 7) >> 3 != (nbits + 7) >> 3:
        return 1
    return 0 if rans.state_ok(data, x0, x1, pos) else 1


def code_static(r: np.ndarray) -> bytes | None:
    """The residual volume (int64, 3-D) as residual type :data:`STATIC_CODED`: the
    activity class count ``n`` (u8), the tables of the ``n`` classes and the
    :data:`N_SIGN` sign contexts (:func:`.fastpredict.pack_tables`), the rANS stream
    (u32 length first) and the raw bits to the end; None where a residual has no token."""
    nz, ny, nx = r.shape
    flat = np.ascontiguousarray(r, np.int64).reshape(-1)
    toks = np.empty(2 * flat.size, np.uint8)
    ctxs = np.empty(2 * flat.size, np.uint8)
    counts = np.zeros((fp.NCLASS + N_SIGN, rans.MAX_SYMBOLS), np.int64)
    bits = np.zeros(5 * flat.size + 16, np.uint8)  # raw fields are at most 30 bits
    nbits, nsym = _static_tokens(flat, nz, ny, nx, toks, ctxs, counts, bits)
    if nbits < 0:
        return None
    nctx, freqs, _ = fp.cap_contexts(counts[: fp.NCLASS])
    freqs = np.vstack([freqs, rans.normalise(counts[fp.NCLASS :])])
    # each context byte's coded context by a table of the 256 (one int64 array a symbol
    # made, not four)
    every = np.arange(256, dtype=np.int64)
    table = np.where(every >= fp.NCLASS, every - fp.NCLASS + nctx, np.minimum(every, nctx - 1))
    ctx = table[ctxs[:nsym]]
    stream = rans.encode(toks[:nsym], ctx, freqs)
    head = bytes([nctx]) + fp.pack_tables(freqs)
    return head + put_section(stream) + bits[: (nbits + 7) >> 3].tobytes()


def decode_static(data, shape) -> np.ndarray:
    """:func:`code_static`'s residuals, flat int64."""
    what = "bounded long-fit residual (static)"
    buf = np.frombuffer(bytes(data), np.uint8)
    nctx = int(buf[0]) if buf.size else 0
    if not 1 <= nctx <= fp.NCLASS:
        raise FormatError(f"{what}: {nctx} activity classes, expected 1..{fp.NCLASS}")
    syms = np.empty((nctx + N_SIGN, rans.TOTAL), np.uint8)
    info = np.empty((nctx + N_SIGN, rans.MAX_SYMBOLS), np.uint32)
    pos = int(fp.tables_kernel(buf, 1, syms, info))
    if pos < 0:
        raise FormatError(f"{what}: {fp.HEAD_STATUS[pos]}")
    stream, pos = take_section(memoryview(buf), pos, what)
    data = np.frombuffer(bytes(stream) + bytes(2), np.uint8)  # padded: see rans
    raw = bytes(buf[pos:])
    words = np.frombuffer(raw + bytes(-len(raw) % 4 + 4), "<u4").astype(np.uint32)
    r = np.empty(int(np.prod(shape)), np.int64)
    scratch = np.empty((2, shape[2]), np.int64)
    cls = np.empty((3, _CLASS_TABLE), np.uint8)
    status = _get_static(data, words, np.int64(8 * len(raw)), syms.reshape(-1),
                         info.reshape(-1), np.int64(nctx), r, *shape, fp.TOK, scratch[0],
                         scratch[1], cls)  # fmt: skip
    if status == 2:
        raise FormatError(f"{what}: a sign symbol past 1")
    if status != 0:
        raise FormatError(f"{what}: the stream does not end where its lengths say")
    return r


def encode_v1(fitted, codec) -> bytes | None:
    """Version 1's bytes of :func:`residuals_v1`' ``(r, w1, w2)``."""
    r, w1, w2 = fitted
    k = (len(w1) - len(w2)) // 3 + 2
    shift = _shifted(r)
    if shift is None:
        return None
    code, lo = shift
    body = codec.encode((r - lo).astype(_DTYPES[code]))
    head = _HEAD.pack(k, code, lo) + w1.astype("<i4").tobytes() + w2.astype("<i4").tobytes()
    return head + body


def encode_head(r: np.ndarray, plan: Plan, weights, context: bool = False, code=None):
    """Version 2's fields before the residual, and the residual to code: shifted to
    start at 0, as its type, for the lossless codec (None where it spans more than 32
    bits), or with ``context`` (type 3, or ``code``: type 4) as it is, for
    :func:`code_residuals` (:func:`code_static`)."""
    if context and code is None:
        code = CONTEXT_CODED
    shift = (code, 0) if code is not None else _shifted(r)
    if shift is None:
        return None
    code, lo = shift
    bits = np.packbits(plan.present).tobytes()
    w = np.concatenate([np.zeros(0, "<i4")] + [v.astype("<i4") for v in weights if v is not None])
    planes = w.view(np.uint8).reshape(-1, 4).T.tobytes()  # byte planes: 16 % shorter zstd'd
    head = _HEAD2.pack(0, *plan.reach, code, lo) + put_section(deflate(bits + planes))
    return head, (r if code >= CONTEXT_CODED else (r - lo).astype(_DTYPES[code]))


def decode(data, shape: tuple[int, ...], qdtype: np.dtype, codec) -> np.ndarray:
    """Decode a long-fit payload (either version) into the quantised voxels."""
    buf = bytes(data)
    if len(shape) != 3 or len(buf) < _HEAD.size:
        raise FormatError("bounded long-fit payload: too short or not a 3-D brick")
    if buf[0] == 0:
        plan, weights, code, lo, pos = _read_v2(buf, shape)
    else:
        plan, weights, code, lo, pos = _read_v1(buf, shape)
    if len(buf) <= pos:
        raise FormatError("bounded long-fit payload: no residuals after the weights")
    if code == CONTEXT_CODED:
        r = decode_residuals(buf[pos:], tuple(shape))
    elif code == STATIC_CODED:
        r = decode_static(buf[pos:], tuple(shape))
    else:
        res = codec.decode(buf[pos:], tuple(shape), np.dtype(_DTYPES[code]))
        r = res.astype(np.int64).reshape(-1) + lo
    q = r  # each voxel written over its residual, which the walk read just before
    qmax = int(np.iinfo(np.dtype(qdtype)).max)
    bad = walk(q, r, plan, weights, qmax, True)
    if bad >= 0:
        raise FormatError(f"bounded long-fit payload: voxel {bad} decodes out of range")
    return q.reshape(shape).astype(qdtype)


def _read_v1(buf: bytes, shape):
    k, code, lo = _HEAD.unpack_from(buf)
    if not 2 <= k <= K_MAX or code >= len(_DTYPES):
        raise FormatError(f"bounded long-fit payload: reach {k} or residual type {code} unknown")
    o1, o2 = long_offsets(k), near_offsets()
    pos = _HEAD.size + 4 * (len(o1) + len(o2))
    if len(buf) < pos:
        raise FormatError("bounded long-fit payload: weights cut")
    w = np.frombuffer(buf[_HEAD.size:pos], "<i4").astype(np.int64)
    if np.abs(w).max(initial=0) > W_LIMIT:
        raise FormatError("bounded long-fit payload: a weight out of range")
    return Plan(shape, (k, k, k), v1=True), [w[: len(o1)], w[len(o1):]], code, lo, pos


def _read_v2(buf: bytes, shape):
    if len(buf) < _HEAD2.size:
        raise FormatError("bounded long-fit payload: version 2 header cut")
    _, kz, ky, kx, code, lo = _HEAD2.unpack_from(buf)
    if code >= CONTEXT_CODED and lo != 0:
        raise FormatError(f"bounded long-fit payload: offset {lo} of a context-coded residual")
    if not all(2 <= k <= K_MAX for k in (kz, ky, kx)) or code > STATIC_CODED:
        raise FormatError(
            f"bounded long-fit payload: reach {(kz, ky, kx)} or residual type {code} unknown"
        )
    plan = Plan(shape, (kz, ky, kx))
    nc = len(plan.offsets)
    nb = (nc + 7) // 8
    limit = nb + 4 * sum(len(o) for o in plan.offsets)
    frame, pos = take_section(memoryview(buf), _HEAD2.size, "bounded long-fit weights")
    body = inflate(frame, limit, "bounded long-fit weights")
    if len(body) < nb:
        raise FormatError("bounded long-fit payload: class bits cut")
    present = np.unpackbits(np.frombuffer(body[:nb], np.uint8), count=nc).astype(bool)
    sizes = [len(o) if p else 0 for o, p in zip(plan.offsets, present)]
    if any(p and not n for p, n in zip(present, sizes)) or len(body) != nb + 4 * sum(sizes):
        raise FormatError("bounded long-fit payload: weights do not match the classes")
    planes = np.frombuffer(body[nb:], np.uint8).reshape(4, -1)
    w = np.ascontiguousarray(planes.T).view("<i4").reshape(-1).astype(np.int64)
    if np.abs(w).max(initial=0) > W_LIMIT:
        raise FormatError("bounded long-fit payload: a weight out of range")
    ends = np.cumsum(sizes)
    weights = [w[e - n:e] if n else None for n, e in zip(sizes, ends)]
    plan.keep(present)
    return plan, weights, code, lo, pos
