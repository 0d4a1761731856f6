"""Exact float coding by prediction on the floats' integer images (float16/32/64).

Two tools, each a way to turn a float brick into integers that a predictor sees as a
smooth field, so that the residuals (not the raw mantissa bits) are coded:

* **Lorenzo** (the predictor of fpzip): a float's bits, read as a signed integer
  ``i``, become ``s = i`` when the sign is clear and ``i XOR (2^(B-1) - 1)`` when it is
  set. ``s`` orders like the floats and has no gap at zero (``-0.0`` is -1, ``+0.0``
  is 0). Each voxel is predicted by the 3-D Lorenzo predictor
  ``W + N + U - NW - UW - UN + UNW`` (2-D or 1-D on the brick's faces) or the 2-D one
  within the slice, summed on the images ``s`` or on the values in float64 and rounded
  back to the float (a field that crosses zero or changes binade leaps in ``s``, not in
  value); the best of the four is chosen per brick by measuring. The residual, wrapped
  to ``B`` bits (so that
  prediction never overflows and the map stays a bijection on bit patterns: NaN
  payloads, -0.0, denormals and Inf come back exactly), is coded by the adaptive
  binary range coder: its bit length on a binary tree (seven decisions, where a unary
  length takes one a bit: the decoder's cost) in a context of the bit lengths of the
  W, N and U residuals, the sign, two bits below the leading one, the rest raw.
* **Lattice** (fields stored as scaled integers, ``value = offset + step * k``: packed
  climate data, with one offset and step per level in GRIB-like packing, fixed-point
  readings): the brick becomes the integer field ``k`` plus
  the gap between each float and ``float(offset + step * k)`` in units in the last
  place, usually 0. Both are integer bricks, coded by the integer lossless tools
  (:mod:`.lossless`: wavelet, fitted prediction, background mask).

The byte layout is in ``formats/lossless-1.md`` (mode 5).
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
from ..entropy.rangecoder import get_bits as _get_bits
from ..entropy.rangecoder import put as _put
from ..entropy.rangecoder import put_bits as _put_bits
from ..errors import FormatError
from .floatbits import from_signed, to_signed
from .predict import bitlen

# The predictors a Lorenzo stream may name: on the integer images, or on the values in
# float64 arithmetic, rounded to the float and mapped (no leap where a field crosses zero
# or changes binade); 3-D or within the slice.
LORENZO3, LORENZO2, LORENZO3F, LORENZO2F = 0, 1, 2, 3
PREDICTORS = (LORENZO3, LORENZO2, LORENZO3F, LORENZO2F)
# Residual models: the bit length (0..64) on a 7-level binary tree in one of NCF
# contexts (7 decisions where a unary length takes one per bit), the sign in 3 sign
# contexts, two bits below the leading one by length and prefix; the rest at one half.
NCF = 128
M_TREE = 0
M_SIGN = M_TREE + NCF * 128
M_MANT = M_SIGN + 3
N_FMODELS = M_MANT + 65 * 4
# Lattice tool: at most this share of voxels off the lattice, else not tried.
LATTICE_MAX_MISS = 0.5
# ... and only when k spans fewer values than the float's significand holds and at
# least 2^3 times fewer than the brick's signed images: a lattice of finer steps (the
# spacing of the floats themselves) codes no shorter than Lorenzo, and coding its two
# integer fields with every integer tool costs most of the encoder's time.
LATTICE_MIN_SAVING = 3


# ---------------------------------------------------------------------------------------
# Lorenzo tool


@kernel(inline=True)
def wrap(v, width):
    """``v`` reduced to the signed range of ``width`` bits (64: numba's int64 wraps)."""
    if width == 64:
        return v
    half = np.int64(1) << (width - 1)
    return ((v + half) & ((half << 1) - 1)) - half


@kernel(inline=True)
def signed_image(q, si, sf, width):
    """Signed image of ``q`` rounded to the float (``sf`` viewed by ``si``)."""
    sf[0] = q
    b = np.int64(si[0])
    return b ^ ((np.int64(1) << (width - 1)) - 1) if b < 0 else b


@kernel(inline=True)
def predict(s, f, si, sf, i, x, y, z, ny, nx, predictor, width):
    """Lorenzo prediction of voxel ``i`` (its signed image) over the axes that have a
    neighbour. The float predictors sum the values in float64, round the sum to the
    float (``sf``, whose bits ``si`` views) and map it; a sum that is NaN falls back to
    the integer predictor."""
    if predictor >= LORENZO3F:
        q = _lorenzo(f, i, x, y, z, ny, nx, predictor == LORENZO3F, np.float64(0.0))
        if q == q:  # not NaN
            return signed_image(q, si, sf, width)
    return _lorenzo(s, i, x, y, z, ny, nx, predictor % 2 == LORENZO3, np.int64(0))


@kernel(inline=True)
def _lorenzo(s, i, x, y, z, ny, nx, volume, p):
    """Lorenzo sum over ``s`` added to ``p`` (a zero of the sum's type)."""
    sy = nx
    sz = ny * nx
    hx = x > 0
    hy = y > 0
    hz = z > 0 and volume
    if hx:
        p += s[i - 1]
    if hy:
        p += s[i - sy]
    if hz:
        p += s[i - sz]
    if hx and hy:
        p -= s[i - sy - 1]
    if hx and hz:
        p -= s[i - sz - 1]
    if hy and hz:
        p -= s[i - sz - sy]
    if hx and hy and hz:
        p += s[i - sz - sy - 1]
    return p


@kernel(inline=True)
def put_residual(out, state, ctx, sctx, r, low, rng, pos):
    """Code residual ``r`` (any int64; -2^63 too): its magnitude's bit length ``L`` on
    the tree, the sign, two bits below the leading one, the rest at one half."""
    return put_residual_at(out, state, M_TREE, ctx, sctx, r, 2, low, rng, pos)


@kernel(inline=True)
def put_residual_at(out, state, base, ctx, sctx, r, nbits, low, rng, pos):
    """:func:`put_residual` with the models from ``base`` on (tree, 3 sign models, then
    ``65 * 2^nbits`` for the ``nbits`` bits below the leading one)."""
    m = -r if r < 0 else r  # -2^63 stays itself: read as unsigned it is 2^63
    nb = bitlen(m)
    node = 1
    for j in range(6, -1, -1):
        bit = (nb >> j) & 1
        low, rng, pos = _put(out, state, base + ctx * 128 + node, bit, low, rng, pos, RATE)
        node = 2 * node + bit
    if nb == 0:
        return low, rng, pos
    msign = base + NCF * 128
    low, rng, pos = _put(out, state, msign + sctx, np.int64(r < 0), low, rng, pos, RATE)
    nm = min(nb - 1, nbits)
    prefix = 1
    for jm in range(nm):
        bit = (m >> (nb - 2 - jm)) & 1
        k = msign + 3 + (nb << nbits) + prefix
        low, rng, pos = _put(out, state, k, bit, low, rng, pos, RATE)
        prefix = 2 * prefix + bit
    return _put_bits(out, np.uint64(m), nb - 1 - nm, low, rng, pos)


@kernel(inline=True)
def get_residual(data, state, ctx, sctx, code, rng, pos):
    """Decode what :func:`put_residual` coded; ``(r, ok, code, rng, pos)`` with ``ok``
    false for a bit length past 64."""
    return get_residual_at(data, state, M_TREE, ctx, sctx, 2, code, rng, pos)


@kernel(inline=True)
def get_residual_at(data, state, base, ctx, sctx, nbits, code, rng, pos):
    """Decode what :func:`put_residual_at` coded."""
    node = 1
    for _ in range(7):
        bit, code, rng, pos = _get(data, state, base + ctx * 128 + node, code, rng, pos, RATE)
        node = 2 * node + bit
    nb = node - 128
    if nb == 0:
        return np.int64(0), True, code, rng, pos
    if nb > 64:
        return np.int64(0), False, code, rng, pos
    msign = base + NCF * 128
    neg, code, rng, pos = _get(data, state, msign + sctx, code, rng, pos, RATE)
    nm = min(nb - 1, nbits)
    prefix = np.int64(1)
    for _ in range(nm):
        k = msign + 3 + (nb << nbits) + prefix
        bit, code, rng, pos = _get(data, state, k, code, rng, pos, RATE)
        prefix = 2 * prefix + bit
    rest = nb - 1 - nm
    v, code, rng, pos = _get_bits(data, np.uint64(0), rest, code, rng, pos)
    m = (prefix << rest) | np.int64(v)
    return (-m if neg else m), True, code, rng, pos


@kernel(inline=True)
def context(el, rs, i, x, y, z, ny, nx):
    """Residual context (bit lengths of the W, N, U residuals, W counted twice, halved)
    and sign context (the sign of the sum of their signs)."""
    act, sctx = activity(el, rs, i, x, y, z, ny, nx)
    return min(act >> 1, NCF - 1), sctx


@kernel(inline=True)
def activity(el, rs, i, x, y, z, ny, nx):
    """``2 lW + lN + lU`` of the bit lengths of the W, N, U residuals (a missing one, or
    one below 0, takes another's; 0 when none is left), and the sign context."""
    lw = el[i - 1] if x > 0 else -1
    ln = el[i - nx] if y > 0 else -1
    lu = el[i - nx * ny] if z > 0 else -1
    if lw < 0:
        lw = ln if ln >= 0 else lu
    if ln < 0:
        ln = lw
    if lu < 0:
        lu = ln
    act = 2 * lw + ln + lu if lw >= 0 else 0
    sg = np.int64(0)
    if x > 0:
        sg += np.sign(rs[i - 1])
    if y > 0:
        sg += np.sign(rs[i - nx])
    if z > 0:
        sg += np.sign(rs[i - nx * ny])
    return act, (0 if sg == 0 else (1 if sg > 0 else 2))


@kernel(nrt=False)
def _encode_kernel(s, f, si, sf, shape, width, predictor, out, el, rs, state):
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
                r = wrap(s[i] - predict(s, f, si, sf, i, x, y, z, ny, nx, predictor, width), width)
                ctx, sctx = context(el, rs, i, x, y, z, ny, nx)
                low, rng, pos = put_residual(out, state, ctx, sctx, r, low, rng, pos)
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(data, shape, width, predictor, s, f, si, sf, el, rs, state):
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
                ctx, sctx = context(el, rs, i, x, y, z, ny, nx)
                r, ok, code, rng, pos = get_residual(data, state, ctx, sctx, code, rng, pos)
                if not ok or r != wrap(r, width):
                    return 2
                v = wrap(predict(s, f, si, sf, i, x, y, z, ny, nx, predictor, width) + r, width)
                s[i] = v
                si[0] = v ^ ((np.int64(1) << (width - 1)) - 1) if v < 0 else v
                f[i] = sf[0]
                rs[i] = r
                el[i] = bitlen(-r if r < 0 else r)
                i += 1
    return end_status(data, code, pos)


def _workspace(n: int) -> tuple[np.ndarray, ...]:
    """Residual bit lengths and residuals of every voxel, and fresh models (the kernels
    run without numba's allocator)."""
    return (
        np.zeros(n, dtype=np.int64),
        np.zeros(n, dtype=np.int64),
        np.full(N_FMODELS, STATE_INIT, dtype=np.uint16),
    )


def scratch(dtype: np.dtype) -> tuple[np.ndarray, np.ndarray]:
    """One float of ``dtype`` and an integer view of its bits (the kernels' bit cast;
    float16, which numba lacks and whose predictors do not cast, gets a float32)."""
    dtype = np.dtype(dtype) if np.dtype(dtype).itemsize >= 4 else np.dtype(np.float32)
    si = np.zeros(1, dtype=f"i{dtype.itemsize}")
    return si, si.view(dtype)


def encode_lorenzo(brick: np.ndarray, predictor: int = LORENZO3) -> bytes:
    """Code a 3-D float brick with one Lorenzo predictor: a predictor byte, then the
    range-coded residuals."""
    if brick.ndim != 3 or brick.dtype.kind != "f" or predictor not in usable(brick.dtype):
        raise ValueError(f"expected a 3-D float brick, found {brick.dtype} {brick.shape}")
    s = to_signed(brick).reshape(-1)
    with np.errstate(invalid="ignore"):  # signalling NaNs
        f = brick.astype(np.float64).reshape(-1)
    si, sf = scratch(brick.dtype)
    width = np.int64(8 * brick.dtype.itemsize)
    shape = np.array(brick.shape, dtype=np.int64)
    p = np.int64(predictor)
    body = encode_with_retry(
        lambda out: _encode_kernel(s, f, si, sf, shape, width, p, out, *_workspace(s.size)),
        s.size,
        (2 * brick.itemsize, 4 * brick.itemsize),
        coder="float Lorenzo",
    )
    return bytes([predictor]) + body


def decode_lorenzo(data: bytes | memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """Decode :func:`encode_lorenzo`'s bytes into a float brick of ``shape``, ``dtype``."""
    buf = stream_bytes(data, "float Lorenzo")
    predictor = int(buf[0])
    if predictor not in usable(dtype):
        raise FormatError(
            f"float Lorenzo payload: expected a predictor in {usable(dtype)} for {np.dtype(dtype)}, "
            f"found {predictor}"
        )
    s = np.empty(int(np.prod(shape)), dtype=np.int64)
    f = np.empty(s.size, dtype=np.float64)
    si, sf = scratch(dtype)
    width = np.int64(8 * np.dtype(dtype).itemsize)
    shp = np.array(shape, dtype=np.int64)
    status = _decode_kernel(
        buf[1:], shp, width, np.int64(predictor), s, f, si, sf, *_workspace(s.size)
    )
    check_status(status, "float Lorenzo")
    return from_signed(s, dtype).reshape(shape)


def usable(dtype: np.dtype) -> tuple[int, ...]:
    """The predictors for floats of ``dtype`` (float16: the integer ones only)."""
    return PREDICTORS if np.dtype(dtype).itemsize >= 4 else (LORENZO3, LORENZO2)


def encode_best_lorenzo(brick: np.ndarray, predictors=None) -> bytes:
    """The shortest Lorenzo stream of the usable predictors (one slice: in-slice only),
    or of ``predictors``."""
    tried = [
        encode_lorenzo(brick, p)
        for p in (usable(brick.dtype) if predictors is None else predictors)
        if brick.shape[0] > 1 or p in (LORENZO2, LORENZO2F)
    ]
    return min(tried, key=len)


# ---------------------------------------------------------------------------------------
# Lattice tool


def rebuild(params: np.ndarray, k: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """``dtype(offset + step * k)``, computed in float64 (IEEE, one rounding per step),
    with ``params`` one ``(offset, step)`` row for the brick or one per z slice."""
    off = params[:, 0].reshape(-1, 1, 1)
    step = params[:, 1].reshape(-1, 1, 1)
    with np.errstate(all="ignore"):
        return (off + step * k.astype(np.float64)).astype(dtype)


MAGNITUDE_STEP = True  # False: the lattices' steps as before session 33 (the A/B compares)
LOW_VALUES = 256  # the distinct values of least magnitude that estimate the step again
NEAR_EQUAL = 1e-3  # a relative gap below this is taken for rounding noise there


def _fit(v: np.ndarray, span: float = np.inf, low: bool = False) -> list[tuple[float, float]]:
    """Candidate ``(offset, step)`` lattices of finite values ``v`` (float64, 1-D): the
    step estimated from the gaps between distinct values (over the whole span, and
    rounded to three significant digits for decimal scale factors), the offset 0 or
    the most common remainder of the values after whole steps (a fill value off the
    lattice does not move it; ``k`` keeps its scale from slice to slice). None when
    every step's ``k`` would span more than ``span`` values (a lattice the caller
    cannot keep: its offsets need not be counted). ``low``: also the step of the values of
    least magnitude (below; for the whole brick's lattice, not each slice's)."""
    s = np.sort(v)
    first = np.empty(s.size, dtype=bool)
    first[:1] = True
    np.not_equal(s[1:], s[:-1], out=first[1:])
    u = s[first]
    if u.size < 3:
        return []
    gaps = np.diff(u)
    est = float(gaps[gaps <= 1.5 * gaps.min()].mean())  # steps of one unit (rounded)
    if not est > 0:
        return []
    steps = {est, round(est, 2 - int(np.floor(np.log10(est))))}
    n = round((u[-1] - u[0]) / est)
    if n >= 1:
        steps.add(float((u[-1] - u[0]) / n))
    # Counts times a constant (a density from counts) computed along two paths differ in
    # their last bits: those near-equal values make the smallest gaps, and so the
    # estimate above, rounding noise. Their error grows with the value, so the step is
    # also taken from the gaps between the values of least magnitude that are more than
    # NEAR_EQUAL of them: the median of those of one unit (results/lossless/fmult33).
    if low and MAGNITUDE_STEP:
        mags = np.abs(u)
        low = np.sort(
            u if u.size <= LOW_VALUES else u[np.argpartition(mags, LOW_VALUES)[:LOW_VALUES]]
        )
        g = np.diff(low)
        g = g[g > NEAR_EQUAL * np.maximum(np.abs(low[1:]), np.abs(low[:-1]))]
        if g.size and (u[-1] - u[0]) / g.min() <= span:
            unit = float(np.median(g[g <= 1.5 * g.min()]))  # one unit, its noise evened
            # ... and the smallest magnitude over its whole units: the multiples of that
            # rebuild the values bit for bit where it is one unit itself
            m = float(np.abs(low[low != 0]).min())
            for new in (unit, m / max(1, round(m / unit))):
                # the low values on it (else its lattice is not tried: a smooth field's
                # steps land anywhere), and not a fraction of a step already there: its
                # lattice holds that one's (as many voxels) with k spanning more values
                off = low / new - np.rint(low / new)
                if np.mean(np.abs(off) < 0.01) >= 0.5 and not any(
                    t >= 1.5 * new and abs(t / new - round(t / new)) < 1e-6 * t / new for t in steps
                ):
                    steps.add(new)
    # (k of any offset spans at least (max - min) / step values; 1e-6: rounding)
    if all(s > 0 and (u[-1] - u[0]) / s * (1 - 1e-6) - 1 > span for s in steps):
        return []
    # (a remainder is the same for equal values: it is taken of the distinct values,
    # each counted as often as it occurs)
    counts = np.diff(np.append(np.flatnonzero(first), s.size))
    out = []
    for step in sorted(steps):
        if step > 0:
            rest = u - step * np.rint(u / step)
            order = np.argsort(rest)  # (equal remainders are the same bits: any order)
            r = rest[order]
            head = np.empty(r.size, dtype=bool)
            head[:1] = True
            np.not_equal(r[1:], r[:-1], out=head[1:])
            count = np.add.reduceat(counts[order], np.flatnonzero(head))
            out += [(0.0, step), (float(r[head][np.argmax(count)]), step)]
    return out


def _lattice_k(brick: np.ndarray, params: np.ndarray, v=None, s=None):
    """``(misses, k, gap)`` of a brick on the lattice(s) ``params``, or ``None`` when
    ``k`` or ``gap`` would not fit int32 (``v``, ``s``: the brick in float64 and its
    signed images, when the caller has them)."""
    v = brick.astype(np.float64) if v is None else v
    off = params[:, 0].reshape(-1, 1, 1)
    step = params[:, 1].reshape(-1, 1, 1)
    with np.errstate(all="ignore"):
        kf = np.rint((v - off) / step)
    if not (np.abs(kf) < 2**31 - 1).all():
        return None
    k = kf.astype(np.int64)
    gap = (to_signed(brick) if s is None else s) - to_signed(rebuild(params, k, brick.dtype))
    if not (np.abs(gap) < 2**31 - 1).all():
        return None
    return int(np.count_nonzero(gap)), k.astype(np.int32), gap.astype(np.int32)


def find_lattices(brick: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """``(params, k, gap)`` for the brick's values on one lattice ``offset + step * k``
    (``params`` one row), and on one lattice per z slice (packed fields: one scale and
    reference value per level), each kept when at most ``LATTICE_MAX_MISS`` of its voxels
    are off it (``gap``: the difference in signed ordered units, int32)."""
    if brick.ndim != 3 or not np.isfinite(brick).all():
        return []
    limit = LATTICE_MAX_MISS * brick.size
    found = []
    best = None
    v, s = brick.astype(np.float64), to_signed(brick)
    span = _span_limit(brick, s)  # k spanning more is not kept (see _narrow)
    for off, step in _fit(v.reshape(-1), span, low=True):
        got = _lattice_k(brick, np.array([[off, step]]), v, s)
        if got is not None and (best is None or got[0] < best[0][0]):
            best = (got, np.array([[off, step]]))
    if best is not None and best[0][0] <= limit and _narrow(brick, best[0][1]):
        found.append((best[1], best[0][1], best[0][2]))
    if brick.shape[0] > 1:
        rows = []
        # (the lattice per slice misses the voxels each slice's pick misses, and its k
        # spans at least each pick's: past the limits, the rest need not be fitted)
        misses, kmin, kmax = 0, np.inf, -np.inf
        for z, sl in enumerate(brick):  # the slice before's lattice is a candidate too
            vz, sz = v[z : z + 1], s[z : z + 1]
            cands = _fit(vz.reshape(-1)) + rows[-1:] + [(0.0, 1.0)]
            scored = [(_lattice_k(sl[None], np.array([c]), vz, sz), c) for c in cands]
            scored = [(g[0], i, c, g[1]) for i, (g, c) in enumerate(scored) if g is not None]
            if not scored:
                return found
            pick = min(scored, key=lambda t: t[:2])
            rows.append(pick[2])
            misses += pick[0]
            kmin, kmax = min(kmin, int(pick[3].min())), max(kmax, int(pick[3].max()))
            if misses > limit or kmax - kmin + 1 > span:
                return found
        params = np.array(rows)
        got = _lattice_k(brick, params)
        if got is not None and found and all(map(np.array_equal, got[1:], found[0][1:])):
            got = None  # the one lattice's k and gap again, under more parameters
        if got is not None and got[0] <= limit and _narrow(brick, got[1]):
            found.append((params, got[1], got[2]))
    return found


def _narrow(brick: np.ndarray, k: np.ndarray) -> bool:
    """Whether ``k`` spans few enough values to be worth a lattice (see
    ``LATTICE_MIN_SAVING``)."""
    return int(k.max()) - int(k.min()) + 1 <= _span_limit(brick, to_signed(brick))


def _span_limit(brick: np.ndarray, s: np.ndarray) -> int:
    """The most values a lattice's ``k`` may span (``s``: the brick's signed images)."""
    sspan = int(s.max()) - int(s.min()) + 1
    significand = np.finfo(brick.dtype).nmant + 1
    return min(1 << significand, sspan >> LATTICE_MIN_SAVING)


def apply_lattice(
    params: np.ndarray, k: np.ndarray, gap: np.ndarray, dtype: np.dtype
) -> np.ndarray:
    """The floats of a lattice payload: the lattice points moved by ``gap`` ordered units,
    wrapped to the float's width (so that any ``gap`` names some bit pattern)."""
    dtype = np.dtype(dtype)
    width = 8 * dtype.itemsize
    s = to_signed(rebuild(params, k, dtype)) + gap.astype(np.int64)
    if width < 64:
        half = np.int64(1) << (width - 1)
        s = ((s + half) & ((half << 1) - 1)) - half
    return from_signed(s, dtype).reshape(k.shape)
