"""Exact float coding by a least-squares predictor fitted per brick (float32/64).

Where a float field's mantissas are full (turbulence, climate levels), the low bits
of every value are noise and most of a voxel's bits are the residual's plain bits:
only a smaller residual helps much. The 3-D Lorenzo predictor (:mod:`.floatpredict`)
passes the noise of seven neighbours on with weights of +-1; a linear predictor over
23 causal neighbours, fitted to the brick by least squares on the values and stored as
23 float32 weights, averages it away (on the Taylor-Green DNS and CAM wind fields:
2-5 % fewer bits than the best Lorenzo predictor). The sum runs in float64, is rounded
to the float and mapped to its signed image; the brick's faces (and a sum that is not
finite) take a Lorenzo predictor named in the payload.

The residual (wrapped to the float's width) is coded as the Lorenzo tool codes it, with
three changes measured on the tuning fields: 16-bit probabilities adapting down to
2^-8 (:func:`.predictfit.put16`), a sign context of the W, N and U residuals' signs
each (27, where the Lorenzo tool sums them into 3: the residuals of a fitted or
Lorenzo predictor keep a sign from voxel to voxel on the CAM fields), and three bits
below the leading one modelled instead of two. The same stream with a Lorenzo
predictor everywhere (no weights) is the other variant. The byte layout is in
``formats/lossless-1.md`` (mode 5, tool 3).

Version 10 (``effort='max'``) adds a box fit inside the 23-neighbour fit's region:
every causal neighbour within ``rz`` slices and ``ry`` rows and ``rx`` columns (337
weights for 1 x 7 x 7, 661 for 1 x 10 x 10), fitted the same way. Neighbours seven to
ten voxels away still carry information on the smooth CAM and DNS fields (a
higher-order fit of the signal under the rounding noise): 14 % fewer bytes on the CAM
zonal wind, 5 % on the DNS x velocity, for about half the decoding speed (hundreds of
products a voxel), so it is not the default.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import (
    end_status,
    finish_stream,
    get_bits,
    open_encoder,
    open_stream,
    put_bits,
)
from ..errors import FormatError
from .floatbits import from_signed, to_signed
from .floatpredict import NCF, activity, predict, scratch, signed_image, usable, wrap
from .predict import bitlen
from .predictfit import MODEL_INIT, get16, put16

# The fitted predictor's neighbours as (dz, dy, dx) steps back, W last: the sum runs in
# this order, and the voxel just decoded enters it last (the other 22 products need not
# wait for it).
FIT_OFFSETS = (
    (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (1, 0, 1), (1, 1, 0), (1, 1, 1),
    (0, 0, 2), (0, 2, 0), (2, 0, 0), (1, 0, -1), (1, -1, 0), (1, 1, -1), (1, -1, 1),
    (1, -1, -1), (0, 1, 2), (0, 2, 1), (0, 2, -1), (2, 1, 0), (2, 0, 1), (1, 2, 0),
    (1, 0, 2), (0, 0, 1),
)  # fmt: skip
NFIT = len(FIT_OFFSETS)  # 23: :func:`_fitted` is written out for this count
FITTED = 4  # predictor byte: 4 + P is the fitted predictor with Lorenzo P on the faces
# 8 + P: also a box fit (version 10) inside the 23-neighbour fit's region
BOXED = 8
# The box fit's half-widths (along z, y, x) the decoder accepts, and those the encoder
# tries (measured on the tuning fields: the CAM wind gains most with 7 rows and columns,
# the DNS x velocity with 10 or more; a second slice back gained less on both).
BOX_MAX = (3, 15, 15)
BOX_SHAPES = ((1, 7, 7), (1, 10, 10))
BOX_FIT_ROWS = 1 << 16  # the box fit's normal equations take at most about this many rows
BOX_TRIM = 16  # the box fit is fitted again without rows past this many median residuals
MANT_BITS = 3  # bits below a residual's leading one coded with models
# Models: the bit length on a 7-level tree in NCF contexts, 27 signs, the mantissa bits.
M_TREE = 0
M_SIGN = M_TREE + NCF * 128
M_MANT = M_SIGN + 27
N_MODELS = M_MANT + (65 << MANT_BITS)
FIT_MIN_ROWS = 4 * NFIT  # fewer interior voxels: no fit
FIT_CHUNK_ROWS = 1 << 16  # rows of the neighbour matrix summed at once (11.5 MB)


@kernel(inline=True)
def _interior(x, y, z, ny, nx):
    """Whether every neighbour of :data:`FIT_OFFSETS` exists."""
    return z >= 2 and y >= 2 and y + 1 < ny and x >= 2 and x + 1 < nx


@kernel(inline=True)
def _fitted(f, w, steps, i):
    """The fitted sum at voxel ``i``: four running sums over the products of the first
    20 neighbours (product ``k`` into sum ``k mod 4``), the next two into the first two
    sums, the sums added pairwise, then W's product: short chains of additions, and the
    voxel just decoded needed only at the end. (Unsigned indices: no test for a wrapped
    negative one.)"""
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    for k in range(0, 20, 4):
        a0 += w[k] * f[np.uint64(i - steps[k])]
        a1 += w[k + 1] * f[np.uint64(i - steps[k + 1])]
        a2 += w[k + 2] * f[np.uint64(i - steps[k + 2])]
        a3 += w[k + 3] * f[np.uint64(i - steps[k + 3])]
    a0 += w[20] * f[np.uint64(i - steps[20])]
    a1 += w[21] * f[np.uint64(i - steps[21])]
    return ((a0 + a1) + (a2 + a3)) + w[22] * f[np.uint64(i - 1)]


@kernel(inline=True)
def _in_box(x, y, z, ny, nx, box):
    """Whether every neighbour of :func:`box_offsets` ``(rz, ry, rx) = box`` exists
    (``rz = 0``: no box fit)."""
    rz, ry, rx = box[0], box[1], box[2]
    return rz > 0 and z >= rz and y >= ry and y + ry < ny and x >= rx and x + rx < nx


@kernel(inline=True)
def _box_sum(f, w, steps, i):
    """The box fit's sum at voxel ``i``: product ``k`` of the first ``K - 1`` into running
    sum ``k mod 4``, the sums added pairwise, then W's product (as :func:`_fitted`)."""
    n = w.size - 1
    a0 = 0.0
    a1 = 0.0
    a2 = 0.0
    a3 = 0.0
    k = 0
    while k + 4 <= n:
        a0 += w[k] * f[np.uint64(i - steps[k])]
        a1 += w[k + 1] * f[np.uint64(i - steps[k + 1])]
        a2 += w[k + 2] * f[np.uint64(i - steps[k + 2])]
        a3 += w[k + 3] * f[np.uint64(i - steps[k + 3])]
        k += 4
    if k < n:
        a0 += w[k] * f[np.uint64(i - steps[k])]
    if k + 1 < n:
        a1 += w[k + 1] * f[np.uint64(i - steps[k + 1])]
    if k + 2 < n:
        a2 += w[k + 2] * f[np.uint64(i - steps[k + 2])]
    return ((a0 + a1) + (a2 + a3)) + w[n] * f[np.uint64(i - 1)]


@kernel(inline=True)
def _predict(s, f, si, sf, w, steps, wb, bsteps, box, i, x, y, z, ny, nx, face, fitted, width):
    """Prediction (signed image) of voxel ``i``: the box fit's sum inside its region,
    else the fitted sum inside the brick when ``fitted``, else (and when a sum is not
    finite) Lorenzo predictor ``face``."""
    if _in_box(x, y, z, ny, nx, box):
        q = _box_sum(f, wb, bsteps, i)
        if q - q == 0.0:
            return signed_image(q, si, sf, width)
    if fitted and _interior(x, y, z, ny, nx):
        q = _fitted(f, w, steps, i)
        if q - q == 0.0:
            return signed_image(q, si, sf, width)
    return predict(s, f, si, sf, i, x, y, z, ny, nx, face, width)


@kernel(inline=True)
def _contexts(el, rs, i, x, y, z, ny, nx):
    """The Lorenzo stream's length context, and the sign context ``9 sW + 3 sN + sU``
    (each 0, 1, 2 for a negative, zero or missing, positive residual)."""
    act, _ = activity(el, rs, i, x, y, z, ny, nx)
    sw = np.sign(rs[i - 1]) + 1 if x > 0 else 1
    sn = np.sign(rs[i - nx]) + 1 if y > 0 else 1
    su = np.sign(rs[i - nx * ny]) + 1 if z > 0 else 1
    return min(act >> 1, NCF - 1), 9 * sw + 3 * sn + su


@kernel(inline=True)
def put_residual(out, models, ctx, sctx, r, low, rng, pos):
    """Code residual ``r`` (any int64): its magnitude's bit length on the tree, the
    sign, ``MANT_BITS`` bits below the leading one, the rest at one half."""
    m = -r if r < 0 else r  # -2^63 stays itself: read as unsigned it is 2^63
    nb = bitlen(m)
    node = 1
    for j in range(6, -1, -1):
        bit = (nb >> j) & 1
        low, rng, pos = put16(out, models, M_TREE + ctx * 128 + node, bit, low, rng, pos)
        node = 2 * node + bit
    if nb == 0:
        return low, rng, pos
    low, rng, pos = put16(out, models, M_SIGN + sctx, np.int64(r < 0), low, rng, pos)
    nm = min(nb - 1, MANT_BITS)
    prefix = 1
    for jm in range(nm):
        bit = (m >> (nb - 2 - jm)) & 1
        low, rng, pos = put16(out, models, M_MANT + (nb << MANT_BITS) + prefix, bit, low, rng, pos)
        prefix = 2 * prefix + bit
    return put_bits(out, np.uint64(m), nb - 1 - nm, low, rng, pos)


@kernel(inline=True)
def get_residual(data, models, ctx, sctx, code, rng, pos):
    """Decode what :func:`put_residual` coded; ``(r, ok, code, rng, pos)`` with ``ok``
    false for a bit length past 64."""
    node = 1
    for _ in range(7):
        bit, code, rng, pos = get16(data, models, M_TREE + ctx * 128 + node, code, rng, pos)
        node = 2 * node + bit
    nb = node - 128
    if nb == 0:
        return np.int64(0), True, code, rng, pos
    if nb > 64:
        return np.int64(0), False, code, rng, pos
    neg, code, rng, pos = get16(data, models, M_SIGN + sctx, code, rng, pos)
    nm = min(nb - 1, MANT_BITS)
    prefix = np.int64(1)
    for _ in range(nm):
        k = M_MANT + (nb << MANT_BITS) + prefix
        bit, code, rng, pos = get16(data, models, k, code, rng, pos)
        prefix = 2 * prefix + bit
    rest = nb - 1 - nm
    v, code, rng, pos = get_bits(data, np.uint64(0), rest, code, rng, pos)
    m = (prefix << rest) | np.int64(v)
    return (-m if neg else m), True, code, rng, pos


@kernel(nrt=False)
def _encode_kernel(
    s, f, si, sf, w, steps, wb, bsteps, box, shape, width, face, fitted, out, el, rs, models
):
    """Return the byte count, -1 when ``out`` is too small."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    cap = out.size
    low, rng, pos = open_encoder(out)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                p = _predict(
                    s, f, si, sf, w, steps, wb, bsteps, box, i, x, y, z, ny, nx, face, fitted, width
                )
                r = wrap(s[i] - p, width)
                ctx, sctx = _contexts(el, rs, i, x, y, z, ny, nx)
                low, rng, pos = put_residual(out, models, ctx, sctx, r, low, rng, pos)
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(
    data, shape, width, face, fitted, w, steps, wb, bsteps, box, s, f, si, sf, el, rs, models
):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    size = data.size
    code, rng, pos = open_stream(data)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos > size + 4:
                    return 1
                ctx, sctx = _contexts(el, rs, i, x, y, z, ny, nx)
                r, ok, code, rng, pos = get_residual(data, models, ctx, sctx, code, rng, pos)
                if not ok or r != wrap(r, width):
                    return 2
                p = _predict(
                    s, f, si, sf, w, steps, wb, bsteps, box, i, x, y, z, ny, nx, face, fitted, width
                )
                v = wrap(p + r, width)
                s[i] = v
                si[0] = v ^ ((np.int64(1) << (width - 1)) - 1) if v < 0 else v
                f[i] = sf[0]
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                i += 1
    return end_status(data, code, pos)


def _workspace(n: int) -> tuple[np.ndarray, ...]:
    """Residual bit lengths and residuals of every voxel, and fresh models."""
    return (
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.full(N_MODELS, MODEL_INIT, dtype=np.uint32),
    )


def _steps(shape: tuple[int, ...], offsets=FIT_OFFSETS) -> np.ndarray:
    """``offsets`` as flat index steps back in a brick of ``shape``."""
    _, ny, nx = shape
    return np.array([(dz * ny + dy) * nx + dx for dz, dy, dx in offsets], dtype=np.int64)


def box_offsets(rz: int, ry: int, rx: int) -> list[tuple[int, int, int]]:
    """The box fit's neighbours as (dz, dy, dx) steps back: every voxel within ``rz``
    slices, ``ry`` rows and ``rx`` columns that comes before the voxel in C order, by
    (dz, dy, dx) descending (the farthest first), W last."""
    out = [
        (dz, dy, dx)
        for dz in range(rz, -1, -1)
        for dy in range(ry, -ry - 1, -1)
        for dx in range(rx, -rx - 1, -1)
        if dz > 0 or dy > 0 or (dy == 0 and dx > 1)
    ]
    return out + [(0, 0, 1)]


def _solve(xtx: np.ndarray, xty: np.ndarray) -> np.ndarray | None:
    """Least-squares weights from the normal equations, as float32, or ``None`` when
    they are not finite."""
    with np.errstate(all="ignore"):
        try:
            w, *_ = np.linalg.lstsq(xtx, xty, rcond=None)
        except np.linalg.LinAlgError:  # an SVD that does not converge (denormal-scale rows)
            return None
        w = w.astype(np.float32)
    return w if np.isfinite(w).all() else None


def _windows(v, offsets, zr, yr, xr) -> tuple[list[np.ndarray], np.ndarray]:
    """The least-squares rows of the voxels ``v[zr[0]:zr[1], yr[0]:yr[1], xr[0]:xr[1]]``
    as views: the window of each neighbour at ``offsets`` (steps back), and the targets."""
    (z0, z1), (y0, y1), (x0, x1) = zr, yr, xr
    cols = [v[z0 - dz : z1 - dz, y0 - dy : y1 - dy, x0 - dx : x1 - dx] for dz, dy, dx in offsets]
    return cols, v[z0:z1, y0:y1, x0:x1]


@kernel(nrt=False)
def _gather_rows(f, steps, idx, x, y):
    """Row ``r`` of ``x``: the values at ``idx[r] - steps`` (one neighbour a column), and
    ``y[r] = f[idx[r]]``: the same numbers as stacking the neighbours' windows, written in
    row order (a stacking writes a column at a time, a stride of K floats apart)."""
    k = steps.size
    for r in range(idx.size):
        i = idx[r]
        for j in range(k):
            x[r, j] = f[i - steps[j]]
        y[r] = f[i]


def fit_rows(f: np.ndarray, steps: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The least-squares rows of the voxels at flat indices ``idx`` of the flattened
    brick ``f`` (float64): a row of the neighbours at ``steps`` back each, and the
    targets (both fits' rows: about ten times faster than stacking their windows)."""
    x = np.empty((idx.size, steps.size))
    y = np.empty(idx.size)
    _gather_rows(f, steps, idx, x, y)
    return x, y


def fit(brick: np.ndarray) -> np.ndarray | None:
    """Least-squares weights (float32, :data:`FIT_OFFSETS` order) of each interior
    voxel's value on its neighbours' (float64; rows with a value that is not finite are
    left out), or ``None`` with too few rows or weights that are not finite.

    The normal equations are summed over slabs of at most :data:`FIT_CHUNK_ROWS` rows,
    so the neighbour matrix is never whole (23 float64 columns of a 2^21-voxel brick
    were 0.4 GB, three copies of it 1.2 GB); a brick of one slab sums as before."""
    nz, ny, nx = brick.shape
    if nz < 3 or ny < 4 or nx < 4:
        return None
    with np.errstate(invalid="ignore"):  # signalling NaNs
        v = brick.astype(np.float64)
    inner = ((2, ny - 1), (2, nx - 1))  # every voxel with all 23 neighbours, from z = 2
    cols, y = _windows(v, FIT_OFFSETS, (2, nz), *inner)
    keep = None
    if not np.isfinite(v).all():
        keep = np.isfinite(y)
        for c in cols:
            keep &= np.isfinite(c)
    count = y.size if keep is None else int(keep.sum())
    if count < FIT_MIN_ROWS:
        return None
    # the normal equations of huge values overflow: scale by the largest value a row uses
    scale = max(float(np.abs(a if keep is None else a[keep]).max()) for a in cols + [y])
    if not scale > 0:
        return None
    plane = (np.arange(2, ny - 1)[:, None] * nx + np.arange(2, nx - 1)).reshape(-1)
    step = max(1, FIT_CHUNK_ROWS // plane.size)
    f, steps = v.reshape(-1), _steps(brick.shape)
    xtx = np.zeros((NFIT, NFIT))
    xty = np.zeros(NFIT)
    with np.errstate(all="ignore"):
        for z0 in range(2, nz, step):
            z1 = min(nz, z0 + step)
            idx = (np.arange(z0, z1)[:, None] * (ny * nx) + plane).reshape(-1)
            x, yc = fit_rows(f, steps, idx)
            if keep is not None:
                k = keep[z0 - 2 : z1 - 2].reshape(-1)
                x, yc = x[k], yc[k]
            x, yc = x / scale, yc / scale
            xtx += x.T @ x
            xty += x.T @ yc
    return _solve(xtx, xty)


def fit_box(brick: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray | None:
    """Least-squares weights (float32, :func:`box_offsets` order) of the voxels whose
    whole box ``shape`` exists, on a subset of whole slices (every ``k``-th, about
    :data:`BOX_FIT_ROWS` rows: the normal equations of K columns cost K^2 a row), fitted
    again without the rows whose residual is past :data:`BOX_TRIM` times the median (a
    few values far out, a special value's neighbours in a smooth field, pull the
    weights of every other voxel); ``None`` as :func:`fit`.

    A slice's rows are gathered once for the normal equations and once for the
    residuals; the refit gathers only the rows it takes out, and solves again only when
    there are any (the same equations, the same weights)."""
    rz, ry, rx = shape
    nz, ny, nx = brick.shape
    offsets = box_offsets(rz, ry, rx)
    rows = (nz - rz) * (ny - 2 * ry) * (nx - 2 * rx)
    if nz <= rz or ny <= 2 * ry or nx <= 2 * rx or rows < 4 * len(offsets):
        return None
    with np.errstate(invalid="ignore"):  # signalling NaNs
        v = brick.astype(np.float64)
    finite = np.isfinite(v)
    scale = np.abs(v[finite]).max() if finite.any() else 0.0
    if not scale > 0:
        return None
    f = (v / scale).reshape(-1)
    steps = _steps(brick.shape, offsets)
    plane = (np.arange(ry, ny - ry)[:, None] * nx + np.arange(rx, nx - rx)).reshape(-1)
    all_finite = bool(finite.all())

    def slab(z):
        """The rows of slice ``z`` with every value finite, and their voxels."""
        idx = z * ny * nx + plane
        x, y = fit_rows(f, steps, idx)
        if all_finite:
            return x, y, idx
        keep = np.isfinite(x).all(axis=1) & np.isfinite(y)
        return x[keep], y[keep], idx[keep]

    k = len(offsets)
    zs = range(rz, nz, -(-rows // BOX_FIT_ROWS))
    xtx, xty, used = np.zeros((k, k)), np.zeros(k), 0
    for z in zs:
        x, y, _ = slab(z)
        xtx += x.T @ x
        xty += x.T @ y
        used += y.size
    w = _solve(xtx, xty) if used >= 4 * k else None
    if w is None:
        return None
    w = w.astype(np.float64)
    errs, voxels = [], []
    for z in zs:
        x, y, idx = slab(z)
        errs.append(np.abs(y - x @ w))
        voxels.append(idx)
    cut = BOX_TRIM * np.median(np.concatenate(errs))
    trimmed = 0
    for e, idx in zip(errs, voxels):
        x, y = fit_rows(f, steps, idx[e > cut])
        xtx -= x.T @ x.copy()  # a general product (numpy's syrk sums x.T @ x otherwise)
        xty -= x.T @ y
        trimmed += y.size
    if not trimmed:
        return w.astype(np.float32)
    used -= trimmed
    return _solve(xtx, xty) if used >= 4 * k else None


def encode(
    brick: np.ndarray,
    face: int,
    weights: np.ndarray | None = None,
    box: tuple[tuple[int, int, int], np.ndarray] | None = None,
) -> bytes:
    """Code a 3-D float32/64 brick: the predictor byte (``face``, the Lorenzo predictor,
    plus :data:`FITTED` with ``weights``, :data:`BOXED` with ``box`` too: its shape's
    three bytes, then its weights after the 23), the weights (float32, little-endian),
    then the range-coded residuals."""
    floats = brick.dtype.name in ("float32", "float64")
    if brick.ndim != 3 or not floats or face not in usable(brick.dtype):
        raise ValueError(f"expected a 3-D float32/64 brick, found {brick.dtype} {brick.shape}")
    if box is not None and weights is None:
        raise ValueError("a box fit needs the 23 weights of the fit around it")
    s = to_signed(brick).reshape(-1)
    with np.errstate(invalid="ignore"):  # signalling NaNs
        f = brick.astype(np.float64).reshape(-1)
    si, sf = scratch(brick.dtype)
    width = np.int64(8 * brick.itemsize)
    shape = np.array(brick.shape, dtype=np.int64)
    fitted = weights is not None
    w = np.zeros(NFIT) if weights is None else np.asarray(weights, "<f4").astype(np.float64)
    head = bytes([face + (BOXED if box is not None else FITTED * fitted)])
    if box is not None:
        head += bytes(box[0])
    if fitted:
        head += np.asarray(weights, "<f4").tobytes()
    box_shape, wb = box if box is not None else ((0, 0, 0), np.zeros(1))
    if box is not None:
        head += np.asarray(wb, "<f4").tobytes()
    wb = np.asarray(wb, "<f4").astype(np.float64)
    bsteps = _steps(brick.shape, box_offsets(*box_shape))
    steps = _steps(brick.shape)
    body = encode_with_retry(
        lambda out: _encode_kernel(
            s, f, si, sf, w, steps, wb, bsteps, np.array(box_shape, dtype=np.int64), shape,
            width, np.int64(face), fitted, out, *_workspace(s.size),
        ),
        s.size,
        (2 * brick.itemsize, 4 * brick.itemsize),
        coder="float fit",
    )  # fmt: skip
    return head + body


def _read_box(buf: np.ndarray) -> tuple[tuple[int, int, int], int]:
    """The box shape after a :data:`BOXED` predictor byte, checked, and its weight count."""
    if buf.size < 4:
        raise FormatError("float fit payload: a box fit without its shape")
    box = (int(buf[1]), int(buf[2]), int(buf[3]))
    if not all(1 <= r <= hi for r, hi in zip(box, BOX_MAX)):
        raise FormatError(f"float fit payload: box half-widths {box} outside 1..{BOX_MAX}")
    return box, len(box_offsets(*box))


def decode(data: bytes | memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """Decode :func:`encode`'s bytes into a float brick of ``shape``, ``dtype``."""
    dtype = np.dtype(dtype)
    buf = stream_bytes(data, "float fit")
    if dtype.name not in ("float32", "float64") or len(shape) != 3:
        raise FormatError(f"float fit payload: expected float32/64 bricks, found {dtype}")
    face, fitted, boxed = int(buf[0]) % FITTED, int(buf[0]) >= FITTED, int(buf[0]) >= BOXED
    if buf[0] >= BOXED + FITTED:
        raise FormatError(f"float fit payload: expected a predictor byte 0..11, found {buf[0]}")
    box, nbox = _read_box(buf) if boxed else ((0, 0, 0), 0)
    pos = 1 + 3 * boxed + 4 * NFIT * fitted
    end = pos + 4 * nbox
    if end >= buf.size:
        raise FormatError("float fit payload: no coded stream after its header")
    w = (
        buf[pos - 4 * NFIT : pos].copy().view("<f4").astype(np.float64)
        if fitted
        else np.zeros(NFIT)
    )
    wb = buf[pos:end].copy().view("<f4").astype(np.float64) if boxed else np.zeros(1)
    n = int(np.prod(shape))
    s = np.empty(n, dtype=np.int64)
    f = np.empty(n, dtype=np.float64)
    si, sf = scratch(dtype)
    status = _decode_kernel(
        buf[end:],
        np.array(shape, dtype=np.int64),
        np.int64(8 * dtype.itemsize),
        np.int64(face),
        fitted,
        w,
        _steps(shape),
        wb,
        _steps(shape, box_offsets(*box)),
        np.array(box, dtype=np.int64),
        s,
        f,
        si,
        sf,
        *_workspace(n),
    )
    check_status(status, "float fit")
    return from_signed(s, dtype).reshape(shape)


def encode_best(brick: np.ndarray, face: int, boxes=()) -> bytes | None:
    """The shortest of the fitted stream (Lorenzo predictor ``face`` on the faces), the
    stream with ``face`` everywhere and the fitted streams with a box fit of each shape in
    ``boxes`` (version 10: :data:`BOX_SHAPES`, narrowest first, the wider ones not tried
    once a box codes no shorter than the fit without one); ``None`` when the brick has no fit (too
    few interior voxels: a small brick, where the coding alone saves a few bytes at most)."""
    w = fit(brick)
    if w is None:
        return None
    out = [encode(brick, face, w), encode(brick, face)]
    for shape in boxes:
        wb = fit_box(brick, shape)
        if wb is None:
            continue
        boxed = encode(brick, face, w, (shape, wb))
        out.append(boxed)
        if len(boxed) >= len(out[0]):
            break  # a box that does not pay: no wider one did on the fields measured
    return min(out, key=len)
