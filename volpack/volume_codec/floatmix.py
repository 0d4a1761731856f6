"""Exact float coding by a blend of predictors, with copies and a fill value (float32/64).

Three things the single Lorenzo predictor (:mod:`.floatpredict`) misses:

* **Which predictor fits changes across a brick.** Rough fields (turbulence, climate
  levels) are predicted better within the slice in one place and across slices in
  another. Each interior voxel is predicted by a weighted mean, on the values in
  float64, of the 3-D Lorenzo predictor, the in-slice plane ``W + N - NW``, the planes
  through ``U`` (``U + W - UW``, ``U + N - UN``) and the single neighbours W, N, U, each
  weighted by the inverse of its error (in units in the last place of the float) summed
  over the W, N, NW, NE and U voxels.
* **Periodic maps.** Density maps of a crystal or a symmetric particle hold a unit cell
  and copies of its edges: a voxel equals the one a fixed offset back (a period along
  an axis). Up to three such offsets are named per brick; for each one that reaches
  back inside the brick a flag (in a context of whether W, N and U were copied by it)
  says that the voxel is that copy, and only the others are predicted.
* **A background.** Thresholded maps (fMRI z-maps), fields over land or sea, masked
  fits hold one value (0, NaN) over much of the volume: a flag in a context of how many
  neighbours hold it says which voxels do, and predictors that would read such a voxel
  are left out of the blend (none left: the last value coded).

The residual (signed images, wrapped to the float's width) is coded as the Lorenzo
tool codes its residuals, with two modelled bits below the leading one and the
blend's error estimate in the context. Faces of the brick take the Lorenzo predictor
of the faces. The byte layout is in ``formats/lossless-1.md`` (mode 5, tool 2).
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import (
    RATE,
    STATE_INIT,
    end_status,
    finish_stream,
    open_encoder,
    open_stream,
)
from ..entropy.rangecoder import get as _get
from ..entropy.rangecoder import put as _put
from ..errors import FormatError
from .floatbits import from_signed, to_signed
from .floatpredict import (
    LORENZO3F,
    NCF,
    activity,
    get_residual_at,
    predict,
    put_residual_at,
    scratch,
    signed_image,
    wrap,
)
from .palette import read_uleb, uleb
from .predict import bitlen

# Predictors (bit k of the set byte): 3-D Lorenzo, in-slice plane, the planes through U
# along x and along y, and W, N, U alone.
NPRED = 7
ALL_PREDICTORS = (1 << NPRED) - 1
MAX_COPIES = 3
MANT_BITS = 2  # bits below a residual's leading one coded with models
M_COPY = NCF * 128 + 3 + (65 << MANT_BITS)  # after the residual models: 8 per copy offset
M_FILL = M_COPY + 8 * MAX_COPIES  # 6 contexts of the fill flag
N_MODELS = M_FILL + 6
ERR_CAP = 1 << 30  # a predictor's error is counted up to this many units
# the neighbours each predictor reads (bits: W, N, U, NW, UW, UN, UNW)
USES = np.array([127, 1 | 2 | 8, 4 | 1 | 16, 4 | 2 | 32, 1, 2, 4], dtype=np.int64)
# the copy offsets the encoder tries: exact repeats at one offset for this share of voxels
COPY_MIN_SHARE = 0.01


@kernel(inline=True)
def _candidates(f, i, sy, sz, pk):
    """The seven predictions of interior voxel ``i`` on the values (float64)."""
    w = f[i - 1]
    n = f[i - sy]
    u = f[i - sz]
    nw = f[i - sy - 1]
    uw = f[i - sz - 1]
    un = f[i - sz - sy]
    unw = f[i - sz - sy - 1]
    pk[0] = w + n + u - nw - uw - un + unw
    pk[1] = w + n - nw
    pk[2] = u + w - uw
    pk[3] = u + n - un
    pk[4] = w
    pk[5] = n
    pk[6] = u


@kernel(inline=True)
def _blend(s, f, si, sf, fl, masked, err, pk, pi, i, x, y, z, ny, nx, nset, width, last):
    """Prediction (signed image) of voxel ``i``; fills ``pi`` with each predictor's
    image (faces: the face Lorenzo prediction for all). Predictors reading a fill voxel
    are left out; with none left, the last voxel coded that was not fill (``last``)."""
    sy = nx
    sz = ny * nx
    if x == 0 or y == 0 or z == 0:
        p = predict(s, f, si, sf, i, x, y, z, ny, nx, np.int64(LORENZO3F), width)
        if masked and ((x > 0 and fl[i - 1]) or (y > 0 and fl[i - sy]) or (z > 0 and fl[i - sz])):
            p = last
        for k in range(NPRED):
            pi[k] = p
        return p, -1.0
    _candidates(f, i, sy, sz, pk)
    near = np.int64(0)
    if masked:
        near = (
            np.int64(fl[i - 1])
            | np.int64(fl[i - sy]) << 1
            | np.int64(fl[i - sz]) << 2
            | np.int64(fl[i - sy - 1]) << 3
            | np.int64(fl[i - sz - 1]) << 4
            | np.int64(fl[i - sz - sy]) << 5
            | np.int64(fl[i - sz - sy - 1]) << 6
        )
    num = 0.0
    den = 0.0
    used = 0
    for k in range(NPRED):
        pi[k] = last
        if not (nset >> k) & 1 or near & USES[k]:
            continue
        q = pk[k]
        if q - q != 0.0:  # NaN or Inf: not blended
            continue
        pi[k] = signed_image(q, si, sf, width)
        e = 1.0 + err[i - 1, k] + err[i - sy, k] + err[i - sy - 1, k] + err[i - sz, k]
        if x + 1 < nx:
            e += err[i - sy + 1, k]
        wk = 1.0 / e
        num += wk * q
        den += wk
        used += 1
    if den > 0.0:
        q = num / den
        if q - q == 0.0:
            return signed_image(q, si, sf, width), used / den
    return last, -1.0


@kernel(inline=True)
def _learn(s, err, pi, i, nset, width):
    """Store each predictor's error at voxel ``i``: the wrapped difference's magnitude,
    capped (-2^63 too)."""
    for k in range(NPRED):
        if (nset >> k) & 1:
            d = wrap(s[i] - pi[k], width)
            d = -d if d < 0 else d
            err[i, k] = d if 0 <= d < ERR_CAP else ERR_CAP


@kernel(inline=True)
def _copy_context(cp, k, i, x, y, z, ny, nx):
    """Context of copy flag ``k``: whether W, N, U were copied by offset ``k``."""
    c = k * 8
    if x > 0 and cp[i - 1] == k + 1:
        c += 1
    if y > 0 and cp[i - nx] == k + 1:
        c += 2
    if z > 0 and cp[i - nx * ny] == k + 1:
        c += 4
    return c


@kernel(inline=True)
def _context(el, rs, est, i, x, y, z, ny, nx):
    """The Lorenzo stream's contexts (a fill neighbour's bit length is missing), the
    activity first averaged with that of the blend's error estimate ``est`` (the
    harmonic mean of the predictors' error sums; below 0 when there is none)."""
    act, sctx = activity(el, rs, i, x, y, z, ny, nx)
    if est >= 0.0:
        act = (act + 4 * bitlen(np.int64(min(est, 1e18)) // 5)) >> 1
    return min(act >> 1, NCF - 1), sctx


@kernel(inline=True)
def _fill_context(fl, i, x, y, z, ny, nx):
    """Context of the fill flag: how many of W, N, NW, NE, U are fill (0..5)."""
    c = 0
    if x > 0:
        c += fl[i - 1]
    if y > 0:
        c += fl[i - nx]
        if x > 0:
            c += fl[i - nx - 1]
        if x + 1 < nx:
            c += fl[i - nx + 1]
    if z > 0:
        c += fl[i - nx * ny]
    return M_FILL + c


@kernel(nrt=False)
def _encode_kernel(
    s, f, si, sf, shape, width, nset, offs, fill, out, el, rs, cp, fl, err, pk, pi, state
):
    """Return the byte count, -1 when ``out`` is too small. ``fill`` (a signed image)
    is coded by a flag when ``fill[1]`` is set."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    ncopy = offs.shape[0]
    cap = out.size
    low, rng, pos = open_encoder(out)
    last = np.int64(0)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                if fill[1]:
                    hit = s[i] == fill[0]
                    c = _fill_context(fl, i, x, y, z, ny, nx)
                    low, rng, pos = _put(out, state, c, np.int64(hit), low, rng, pos, RATE)
                    if hit:
                        fl[i] = 1
                        el[i] = -1
                        i += 1
                        continue
                p, est = _blend(
                    s, f, si, sf, fl, fill[1], err, pk, pi, i, x, y, z, ny, nx, nset, width, last
                )
                _learn(s, err, pi, i, nset, width)
                copied = False
                for k in range(ncopy):
                    if z >= offs[k, 0] and y >= offs[k, 1] and x >= offs[k, 2]:
                        j = i - (offs[k, 0] * ny + offs[k, 1]) * nx - offs[k, 2]
                        hit = s[j] == s[i]
                        c = M_COPY + _copy_context(cp, k, i, x, y, z, ny, nx)
                        low, rng, pos = _put(out, state, c, np.int64(hit), low, rng, pos, RATE)
                        if hit:
                            cp[i] = k + 1
                            copied = True
                            break
                r = np.int64(0)
                if not copied:
                    r = wrap(s[i] - p, width)
                    ctx, sctx = _context(el, rs, est, i, x, y, z, ny, nx)
                    low, rng, pos = put_residual_at(
                        out, state, 0, ctx, sctx, r, MANT_BITS, low, rng, pos
                    )
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                last = s[i]
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(
    data, shape, width, nset, offs, fill, s, f, si, sf, el, rs, cp, fl, err, pk, pi, state
):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    ncopy = offs.shape[0]
    size = data.size
    code, rng, pos = open_stream(data)
    last = np.int64(0)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos > size + 4:
                    return 1
                if fill[1]:
                    c = _fill_context(fl, i, x, y, z, ny, nx)
                    hit, code, rng, pos = _get(data, state, c, code, rng, pos, RATE)
                    if hit:
                        s[i] = fill[0]
                        si[0] = (
                            fill[0] ^ ((np.int64(1) << (width - 1)) - 1) if fill[0] < 0 else fill[0]
                        )
                        f[i] = sf[0]
                        fl[i] = 1
                        el[i] = -1
                        i += 1
                        continue
                p, est = _blend(
                    s, f, si, sf, fl, fill[1], err, pk, pi, i, x, y, z, ny, nx, nset, width, last
                )
                copied = False
                for k in range(ncopy):
                    if z >= offs[k, 0] and y >= offs[k, 1] and x >= offs[k, 2]:
                        c = M_COPY + _copy_context(cp, k, i, x, y, z, ny, nx)
                        hit, code, rng, pos = _get(data, state, c, code, rng, pos, RATE)
                        if hit:
                            j = i - (offs[k, 0] * ny + offs[k, 1]) * nx - offs[k, 2]
                            s[i] = s[j]
                            cp[i] = k + 1
                            copied = True
                            break
                r = np.int64(0)
                if not copied:
                    ctx, sctx = _context(el, rs, est, i, x, y, z, ny, nx)
                    r, ok, code, rng, pos = get_residual_at(
                        data, state, 0, ctx, sctx, MANT_BITS, code, rng, pos
                    )
                    if not ok or r != wrap(r, width):
                        return 2
                    s[i] = wrap(p + r, width)
                v = s[i]
                si[0] = v ^ ((np.int64(1) << (width - 1)) - 1) if v < 0 else v
                f[i] = sf[0]
                _learn(s, err, pi, i, nset, width)
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                last = v
                i += 1
    return end_status(data, code, pos)


def _workspace(n: int) -> tuple[np.ndarray, ...]:
    """Residual bit lengths, residuals, copy marks and predictor errors of every voxel,
    the predictions of one voxel, fresh models (the kernels run without numba's
    allocator)."""
    return (
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.int8),
        np.zeros(n, dtype=np.int8),
        np.zeros((n, NPRED + 1), dtype=np.int32),
        np.zeros(NPRED, dtype=np.float64),
        np.zeros(NPRED, dtype=np.int64),
        np.full(N_MODELS, STATE_INIT, dtype=np.uint16),
    )


def encode(brick: np.ndarray, nset: int = ALL_PREDICTORS, offsets=(), fill=None) -> bytes:
    """Code a 3-D float32/float64 brick with the predictor set ``nset`` (bit k:
    predictor k), the copy ``offsets`` ((dz, dy, dx) each, at most three) and a
    ``fill`` value (a float of the brick's dtype, compared by its bits) or none."""
    if brick.ndim != 3 or brick.dtype.name not in ("float32", "float64"):
        raise ValueError(f"expected a 3-D float32/64 brick, found {brick.dtype} {brick.shape}")
    offs = np.array(list(offsets), dtype=np.int64).reshape(-1, 3)
    s = to_signed(brick).reshape(-1)
    with np.errstate(invalid="ignore"):  # signalling NaNs
        f = brick.astype(np.float64).reshape(-1)
    si, sf = scratch(brick.dtype)
    width = np.int64(8 * brick.dtype.itemsize)
    shape = np.array(brick.shape, dtype=np.int64)
    fv = np.zeros(2, dtype=np.int64)
    head = bytes([nset, len(offs) | (4 if fill is not None else 0)])
    head += b"".join(uleb(int(v)) for v in offs.reshape(-1))
    if fill is not None:
        one = np.array([fill], dtype=brick.dtype)
        fv[:] = to_signed(one)[0], 1
        head += one.tobytes()
    body = encode_with_retry(
        lambda out: _encode_kernel(
            s, f, si, sf, shape, width, np.int64(nset), offs, fv, out, *_workspace(s.size)
        ),
        s.size,
        (2 * brick.itemsize, 4 * brick.itemsize),
        coder="float blend",
    )
    return head + body


def decode(data: bytes | memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """Decode :func:`encode`'s bytes into a float brick of ``shape``, ``dtype``."""
    dtype = np.dtype(dtype)
    buf = stream_bytes(data, "float blend")
    if dtype.name not in ("float32", "float64") or len(shape) != 3:
        raise FormatError(f"float blend payload: expected float32/64 bricks, found {dtype}")
    nset, kinds = int(buf[0]), int(buf[1]) if buf.size > 1 else 0xFF
    ncopy, has_fill = kinds & 3, kinds & 4
    if not 0 < nset <= ALL_PREDICTORS or kinds > 7:
        raise FormatError(
            f"float blend payload: expected a predictor set 1..{ALL_PREDICTORS} and a "
            f"byte 0..7 of copies and fill, found {nset} and {kinds}"
        )
    pos = 2
    vals = []
    for _ in range(3 * ncopy):
        v, pos = read_uleb(buf, pos)
        vals.append(min(v, 1 << 32))
    offs = np.array(vals, dtype=np.int64).reshape(-1, 3)
    if any(not row.any() or (row >= np.array(shape)).any() for row in offs):
        raise FormatError(f"float blend payload: copy offsets {offs.tolist()} do not fit {shape}")
    fv = np.zeros(2, dtype=np.int64)
    if has_fill:
        one = buf[pos : pos + dtype.itemsize].copy()
        if one.size < dtype.itemsize:
            raise FormatError("float blend payload: its fill value runs past the payload")
        fv[:] = to_signed(one.view(dtype))[0], 1
        pos += dtype.itemsize
    if pos >= buf.size:
        raise FormatError("float blend payload: no coded stream after its header")
    n = int(np.prod(shape))
    s = np.empty(n, dtype=np.int64)
    f = np.empty(n, dtype=np.float64)
    si, sf = scratch(dtype)
    width = np.int64(8 * dtype.itemsize)
    shp = np.array(shape, dtype=np.int64)
    status = _decode_kernel(
        buf[pos:], shp, width, np.int64(nset), offs, fv, s, f, si, sf, *_workspace(n)
    )
    check_status(status, "float blend")
    return from_signed(s, dtype).reshape(shape)


def copy_offsets(brick: np.ndarray, limit: int = MAX_COPIES) -> list[tuple[int, int, int]]:
    """The offsets ``(dz, dy, dx)`` (each >= 0) at which at least ``COPY_MIN_SHARE`` of
    the voxels repeat the nearest earlier voxel of the same bits exactly; periods along
    one axis first (a unit cell's copies; a diagonal offset is mostly two of them
    combined), then by share; not the single steps W, N, U (the predictor codes those)."""
    bits = np.ascontiguousarray(brick).reshape(-1).view(f"u{brick.itemsize}")
    order = np.argsort(bits, kind="stable")
    same = bits[order[1:]] == bits[order[:-1]]
    dist = (order[1:] - order[:-1])[same]
    d, count = np.unique(dist, return_counts=True)
    keep = count >= COPY_MIN_SHARE * bits.size
    nz, ny, nx = brick.shape
    found = []
    for dd, c in zip(d[keep].tolist(), count[keep].tolist()):
        dz, rest = divmod(dd, ny * nx)
        dy, dx = divmod(rest, nx)
        if dz + dy + dx > 1 and (dz, dy, dx) not in ((0, 1, 0), (1, 0, 0)):
            found.append(((dz > 0) + (dy > 0) + (dx > 0), -c, (dz, dy, dx)))
    return [off for _, _, off in sorted(found)[:limit]]


def fill_value(brick: np.ndarray, share: float = 0.1):
    """The brick's most common value (by bits) when it covers at least ``share`` of
    the voxels, else ``None``."""
    bits = np.ascontiguousarray(brick).reshape(-1).view(f"u{brick.itemsize}")
    v, count = np.unique(bits, return_counts=True)
    j = int(np.argmax(count))
    return v[j : j + 1].view(brick.dtype)[0] if count[j] >= share * bits.size else None
