"""3-D predictive coding of integer voxels: the lossless path for scans with sharp edges.

A wavelet spreads one sharp edge (a skull-stripped brain against a zeroed background,
the border of a label) over many coefficients at every level; a predictor pays for it
once, at the voxels on the edge. Voxels are visited in C order (z, y, x). Each is
predicted from its causal neighbours in its own slice and the slice before, by several
simple predictors blended with weights that follow how well each did on the
neighbours (the weighted-predictor idea of lossless image coders, in 3-D):

=====  ===================================  =====================================
index  predictor                            good for
=====  ===================================  =====================================
0      ``W + N - NW``                       in-plane gradients
1      ``U + W - UW``                       gradients across slices (x, z)
2      ``U + N - UN``                       gradients across slices (y, z)
3      ``W + N + U - NW - UW - UN + UNW``   smooth 3-D fields (Lorenzo)
4      ``U``                                slices that repeat
5      ``(W + N + 1) >> 1`` .. see code     noisy flat regions
=====  ===================================  =====================================

(``W``, ``N``, ``U`` are the neighbours one step back along x, y and z; a missing one
falls back to another, see :func:`_neighbours`.) Predictor ``i`` gets the weight
about ``2^24 / (1 + s_i)`` where ``s_i`` sums its absolute errors at the neighbours W, N, NE,
NW and U; the blend, plus a per-context bias correction, clipped to the value range,
is the prediction.

The residual is coded with the adaptive binary range coder of
:mod:`volpack.entropy.rangecoder` in a context ``c`` that measures how large the errors
around the voxel were (``|e_W| + |e_N| + |e_U| + (|e_NW| + |e_NE|) / 2`` on a
logarithmic scale, 48 classes) and how far the six predictors disagree (3 classes
against that activity): a zero flag, the sign, the bit length of ``|r| - 1``
in unary, two bits below its leading one with adaptive probabilities, the rest at one
half. A flat background costs a few hundredths of a bit a voxel; an edge costs its
jump once.

Values may first be replaced by their rank among the values the brick uses
(:mod:`.palette`); the predictor then works on ranks. Floats reach this module as
the order-preserving integer image of their bits (:mod:`.floatbits`).
The byte layout is in ``formats/lossless-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, leading_zeros
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import STATE_INIT, end_status, finish_stream, open_encoder, open_stream
from ..entropy.rangecoder import digit as _digit
from ..entropy.rangecoder import get as _get
from ..entropy.rangecoder import pull as _pull
from ..entropy.rangecoder import push as _push
from ..entropy.rangecoder import put as _put
from ..errors import FormatError, OptionError

NPRED = 6
PSTRIDE = 8  # ring entries per voxel for the predictors' errors (6 used; aligned)
NACT = 48  # activity classes
NSPREAD = 3  # classes of the predictors' spread relative to the activity
NCTX = NACT * NSPREAD
NLEN = 66  # bit lengths 0..65 of |r| - 1 (residuals of 64-bit values fit)
# Model layout: zero flags, signs (3 sign contexts), unary bit lengths, mantissa bits.
M_ZERO = 0
M_SIGN = M_ZERO + NCTX
M_LEN = M_SIGN + NCTX * 3
M_MANT = M_LEN + NCTX * NLEN
N_MODELS = M_MANT + NLEN * 4 * 4
# Array indices in the kernels are cast to unsigned (``v[np.uint64(i - sy)]``): numba
# wraps a negative signed index, a compare and a select at every access (the predict2
# decoder took 1.08-1.17x the time with them).
NO_RESIDUAL = np.int64(-(1 << 62))  # get_residual's answer to an impossible length
# Adaptation rates by use count (as rangecoder.RATE, but settling slower: a brick of
# prediction residuals is long and its statistics steady).
RATE = np.array([1, 2, 2, 3, 3, 3, 4, 4, 4, 5, 5, 5, 6, 6, 6, 7], dtype=np.int64)
BIAS_LIMIT = 64  # halve a context's error sum and count when the count reaches this
# 2^24 // t for t < 256: predictor weights without a division (see weight).
RECIP = np.array([0] + [(1 << 24) // t for t in range(1, 256)], dtype=np.int64)


@kernel(inline=True)
def bitlen(u):
    return 64 - np.int64(leading_zeros(np.uint64(u)))


@kernel(inline=True)
def activity_class(a):
    """Logarithmic class of a non-negative error sum: 0..3 exactly, then two classes
    per power of two, capped at NCTX - 1."""
    b = bitlen(a | 4)
    c = min(2 * b - 2 + ((a >> (b - 2)) & 1), NACT - 1)
    return a if a < 4 else c


@kernel(inline=True)
def put_residual(out, state, base, ctx, sctx, r, low, rng, pos, rate):
    """Code residual ``r`` in context ``ctx`` (sign context ``sctx``) with the models
    from ``base`` on, adapting at ``rate``: a zero flag, the sign, the bit length of ``|r| - 1`` in unary, two
    bits below its leading one with adaptive probabilities, the rest at one half."""
    bit = np.int64(r != 0)
    low, rng, pos = _put(out, state, base + M_ZERO + ctx, bit, low, rng, pos, rate)
    if r == 0:
        return low, rng, pos
    bit = np.int64(r < 0)
    low, rng, pos = _put(out, state, base + M_SIGN + ctx * 3 + sctx, bit, low, rng, pos, rate)
    u = abs(r) - 1
    nb = bitlen(u)
    k0 = base + M_LEN + ctx * NLEN
    for j in range(min(nb + 1, NLEN - 1)):
        low, rng, pos = _put(out, state, k0 + j, np.int64(nb > j), low, rng, pos, rate)
    nm = min(nb - 1, 2)
    prefix = 1
    for jm in range(nm):
        bit = (u >> (nb - 2 - jm)) & 1
        k = base + M_MANT + (nb * 4 + prefix) * 4 + min(ctx >> 3, 3)
        low, rng, pos = _put(out, state, k, bit, low, rng, pos, rate)
        prefix = 2 * prefix + bit
    kr = nb - 1 - max(nm, 0)
    while kr > 0:
        t = min(kr, 16)
        kr -= t
        rng >>= t
        low += ((u >> kr) & ((1 << t) - 1)) * rng
        low, rng, pos = _push(out, low, rng, pos)
    return low, rng, pos


@kernel(inline=True)
def get_residual(data, state, base, ctx, sctx, code, rng, pos, rate):
    """Decode what :func:`put_residual` coded; ``NO_RESIDUAL`` for an impossible one."""
    bit, code, rng, pos = _get(data, state, base + M_ZERO + ctx, code, rng, pos, rate)
    if bit == 0:
        return np.int64(0), code, rng, pos
    k = base + M_SIGN + ctx * 3 + sctx
    neg, code, rng, pos = _get(data, state, k, code, rng, pos, rate)
    k0 = base + M_LEN + ctx * NLEN
    nb = 0
    while nb < NLEN - 1:
        bit, code, rng, pos = _get(data, state, k0 + nb, code, rng, pos, rate)
        if bit == 0:
            break
        nb += 1
    if nb > 62:
        return NO_RESIDUAL, code, rng, pos
    u = np.int64(1 if nb >= 1 else 0)
    nm = min(nb - 1, 2)
    prefix = 1
    for _ in range(nm):
        k = base + M_MANT + (nb * 4 + prefix) * 4 + min(ctx >> 3, 3)
        bit, code, rng, pos = _get(data, state, k, code, rng, pos, rate)
        prefix = 2 * prefix + bit
        u = (u << 1) | bit
    kr = nb - 1 - max(nm, 0)
    while kr > 0:
        t = min(kr, 16)
        kr -= t
        rng >>= t
        q = _digit(code, rng)
        if q >= (1 << t):  # past the last of the 2^t parts: only damage points there
            return NO_RESIDUAL, code, rng, pos
        code -= q * rng
        u = (u << t) | q
        code, rng, pos = _pull(data, code, rng, pos)
    return (-(u + 1) if neg else u + 1), code, rng, pos


@kernel(inline=True)
def weight(t):
    """About ``2^24 / t`` for ``t >= 1`` from eight bits of ``t`` (no division); >= 1.
    Branch-free: ``t < 256`` is a shift of zero."""
    sh = max(bitlen(t) - 8, 0)
    return max(RECIP[np.uint64(t >> sh)] >> sh, 1)


@kernel(inline=True)
def floor_div(a, d):
    """``a // d`` for ``1 <= d < 2^53`` and ``|a / d| < 2^48`` (here a weighted mean of
    predictions of values below 2^32 in magnitude): the floor of a float quotient,
    corrected by its remainder (a 64-bit integer division costs several times more).
    The float quotient is within ``2^-51 |a / d| < 1/8`` of the true one, so its floor
    is off by at most one either way (only where the true quotient lies that close to
    an integer); the correction is branch-free."""
    q = np.int64(np.floor(np.float64(a) / np.float64(d)))
    r = a - q * d
    return q + np.int64(r >= d) - np.int64(r < 0)


@kernel(inline=True)
def floor_div_nonneg(a, d):
    """:func:`floor_div` for ``a >= 0``: the float quotient truncated (one instruction,
    where a floor is a rounding step more on the decoder's chain) is then its floor,
    and the same correction makes it exact. (A negative quotient truncates towards
    zero, which with the float's own error can be off by two: not for this one.) The
    correction is a branch, not arithmetic: it is almost never taken."""
    return _floor_fix(a, d, np.int64(np.float64(a) / np.float64(d)))


@kernel(inline=True)
def _floor_fix(a, d, q):
    """``a // d`` from ``q``, a quotient off by at most one (``a >= 0``, ``d > 0``)."""
    r = a - q * d
    if r < 0 or r >= d:  # (rare: a branch the CPU guesses right and the decoder's chain
        q += np.int64(r >= d) - np.int64(r < 0)  # goes on with q, not waiting for r)
    return q


@kernel(inline=True)
def floor_div_recip(a, d, rd):
    """:func:`floor_div_nonneg` by a multiply with ``rd``, the double nearest ``1 / d``
    (worked out by the caller as soon as ``d`` is known). Three roundings (``a``,
    ``1 / d``, the product) leave the product within ``2^-51`` of ``a / d`` relatively,
    under ``1/8`` for quotients below ``2^48``: the truncation is off by at most one and
    the same correction makes it exact."""
    return _floor_fix(a, d, np.int64(np.float64(a) * rd))


@kernel(inline=True)
def add_errors(perr, j, s0, s1, s2, s3, s4, s5):
    """The predictors' error sums plus those of the voxel at ring slot ``j``."""
    b = j * PSTRIDE
    return (
        s0 + perr[np.uint64(b)],
        s1 + perr[np.uint64(b + 1)],
        s2 + perr[np.uint64(b + 2)],
        s3 + perr[np.uint64(b + 3)],
        s4 + perr[np.uint64(b + 4)],
        s5 + perr[np.uint64(b + 5)],
    )


@kernel(inline=True)
def context(act, spread):
    """The coding context: the activity class, split by how far the predictors
    disagree (``spread``) against the activity."""
    wide = np.int64(2 * spread > act) + np.int64(spread > 2 * act + 1)
    return activity_class(act) * NSPREAD + wide


@kernel(inline=True)
def mean_error(s, c):
    """Error sum ``s`` over count ``c`` (below 64), rounded half away from zero, by a
    reciprocal (RECIP[0] is 0). Branch-free: the signs are coin tosses."""
    sg = s >> 63
    t = ((((s ^ sg) - sg) * RECIP[np.uint64(c)]) + (1 << 23)) >> 24
    return (t ^ sg) - sg


@kernel(inline=True)
def context_bias(bias_sum, bias_cnt, ctx):
    """The context's mean error (:func:`mean_error`)."""
    return mean_error(bias_sum[np.uint64(ctx)], bias_cnt[np.uint64(ctx)])


@kernel(inline=True)
def learn_bias(bias_sum, bias_cnt, ctx, e):
    """Add error ``e`` to the context's sum and count; both halve at BIAS_LIMIT.
    Returns the new ``(sum, count)``."""
    s = bias_sum[np.uint64(ctx)] + e
    c = bias_cnt[np.uint64(ctx)] + 1
    if c >= BIAS_LIMIT:
        s = s // 2 if s >= 0 else -((-s) // 2)
        c >>= 1
    bias_sum[np.uint64(ctx)] = s
    bias_cnt[np.uint64(ctx)] = c
    return s, c


@kernel(inline=True)
def interior(v, err, perr, i, r, ru, sy, sz, W, eW, s0, s1, s2, s3, s4, s5):
    """:func:`gather` for a voxel inside the brick, whose every neighbour is there, given
    the voxel before's value ``W``, its final error ``eW`` and the predictors' error sums
    with its errors already added (``s0..s5``)."""
    N = v[np.uint64(i - sy)]
    U = v[np.uint64(i - sz)]
    NW = v[np.uint64(i - sy - 1)]
    NE = v[np.uint64(i - sy + 1)]
    UW = v[np.uint64(i - sz - 1)]
    UN = v[np.uint64(i - sz - sy)]
    UNW = v[np.uint64(i - sz - sy - 1)]
    eN = err[np.uint64(r - sy)]
    eU = err[np.uint64(ru)]
    act2 = (
        2 * (abs(eW) + abs(eN) + abs(eU))
        + abs(err[np.uint64(r - sy - 1)])
        + abs(err[np.uint64(r - sy + 1)])
    )
    esum = eW + eN + eU
    s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy, s0, s1, s2, s3, s4, s5)
    s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy - 1, s0, s1, s2, s3, s4, s5)
    s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy + 1, s0, s1, s2, s3, s4, s5)
    s0, s1, s2, s3, s4, s5 = add_errors(perr, ru, s0, s1, s2, s3, s4, s5)
    return W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5


@kernel(inline=True)
def gather(v, err, perr, i, r, ru, z, y, x, ny, nx, lo, hi):
    """The causal neighbours of voxel ``i`` = (z, y, x) in the decoded ``v`` (with
    fallbacks at the brick's faces), twice the activity of the final errors ``err``
    around it, their sum, and each predictor's error sum at the neighbours, from the
    ring of two slices ``err``, ``perr`` (``r`` is the voxel's slot, ``ru`` the slot of U).

    Returns ``(W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, ..., s5)``.
    """
    sy = nx
    sz = ny * nx
    hw = x > 0
    hn = y > 0
    hu = z > 0
    he = x + 1 < nx
    s0 = s1 = s2 = s3 = s4 = s5 = np.int64(0)
    if hw and hn and hu and he:  # inside the brick: every neighbour there (most voxels)
        s0, s1, s2, s3, s4, s5 = add_errors(perr, r - 1, s0, s1, s2, s3, s4, s5)
        W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5 = interior(
            v, err, perr, i, r, ru, sy, sz, v[np.uint64(i - 1)], err[np.uint64(r - 1)],
            s0, s1, s2, s3, s4, s5,
        )  # fmt: skip
    else:
        # Neighbours, with fallbacks that turn each predictor into a lower-dimensional one.
        if hw:
            W = v[np.uint64(i - 1)]
        elif hn:
            W = v[np.uint64(i - sy)]
        elif hu:
            W = v[np.uint64(i - sz)]
        else:
            W = (lo + hi) >> 1
        N = v[np.uint64(i - sy)] if hn else W
        U = v[np.uint64(i - sz)] if hu else W
        NW = v[np.uint64(i - sy - 1)] if hn and hw else N
        NE = v[np.uint64(i - sy + 1)] if hn and he else N
        UW = v[np.uint64(i - sz - 1)] if hu and hw else U
        UN = v[np.uint64(i - sz - sy)] if hu and hn else U
        UNW = v[np.uint64(i - sz - sy - 1)] if hu and hn and hw else UN + UW - U
        # Each predictor's error sum at the neighbours, and the activity of the errors.
        act2 = np.int64(0)  # twice the activity
        esum = np.int64(0)
        if hw:
            act2 += 2 * abs(err[np.uint64(r - 1)])
            esum += err[np.uint64(r - 1)]
            s0, s1, s2, s3, s4, s5 = add_errors(perr, r - 1, s0, s1, s2, s3, s4, s5)
        if hn:
            act2 += 2 * abs(err[np.uint64(r - sy)])
            esum += err[np.uint64(r - sy)]
            s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy, s0, s1, s2, s3, s4, s5)
            if hw:
                act2 += abs(err[np.uint64(r - sy - 1)])
                s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy - 1, s0, s1, s2, s3, s4, s5)
            if he:
                act2 += abs(err[np.uint64(r - sy + 1)])
                s0, s1, s2, s3, s4, s5 = add_errors(perr, r - sy + 1, s0, s1, s2, s3, s4, s5)
        if hu:
            act2 += 2 * abs(err[np.uint64(ru)])
            esum += err[np.uint64(ru)]
            s0, s1, s2, s3, s4, s5 = add_errors(perr, ru, s0, s1, s2, s3, s4, s5)
    return W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5


@kernel(inline=True)
def _predict_kernel(v, err, perr, i, r, ru, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt):
    """Prediction and contexts of voxel ``i`` = (z, y, x) from the decoded ``v``, and the
    final errors ``err`` and per-predictor errors ``perr`` of earlier voxels, kept in a
    ring of two slices (``r`` is the voxel's slot, ``ru`` the slot of U).

    Returns ``(pred, ctx, sign_ctx, p0, ..., p5)`` (the six predictors' values).
    """
    W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5 = gather(
        v, err, perr, i, r, ru, z, y, x, ny, nx, lo, hi
    )
    p0 = W + N - NW
    p1 = U + W - UW
    p2 = U + N - UN
    p3 = W + N + U - NW - UW - UN + UNW
    p4 = U
    p5 = (W + NE + 1) >> 1
    act = act2 >> 1
    # Blend with weights ~ 2^24 / (1 + s_k) (at least 1); the sums stay below 2^63 for
    # a value range below 2^32.
    w0 = weight(s0 + 1)
    w1 = weight(s1 + 1)
    w2 = weight(s2 + 1)
    w3 = weight(s3 + 1)
    w4 = weight(s4 + 1)
    w5 = weight(s5 + 1)
    num = w0 * p0 + w1 * p1 + w2 * p2 + w3 * p3 + w4 * p4 + w5 * p5
    den = w0 + w1 + w2 + w3 + w4 + w5
    pred = floor_div(num + (den >> 1), den)
    ctx = context(act, max(p0, p1, p2, p3, p4, p5) - min(p0, p1, p2, p3, p4, p5))
    pred += context_bias(bias_sum, bias_cnt, ctx)
    pred = min(max(pred, lo), hi)
    sctx = np.int64(esum > 0) + 2 * np.int64(esum < 0)
    return pred, ctx, sctx, p0, p1, p2, p3, p4, p5


@kernel(inline=True)
def _learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, p0, p1, p2, p3, p4, p5):
    """After voxel ``val`` at ring slot ``r`` is known: store its errors and update the
    context's bias."""
    e = val - pred
    store_errors(err, perr, r, e, val, p0, p1, p2, p3, p4, p5)
    learn_bias(bias_sum, bias_cnt, ctx, e)


@kernel(inline=True)
def store_errors(err, perr, r, e, val, p0, p1, p2, p3, p4, p5):
    """Ring slot ``r``'s final error ``e`` and each predictor's error against ``val``
    (capped at 2^30 - 1, so that five of them add up within an int32's reach); returns
    the six capped errors."""
    err[np.uint64(r)] = e
    b = r * PSTRIDE
    a0 = min(abs(val - p0), 0x3FFFFFFF)
    a1 = min(abs(val - p1), 0x3FFFFFFF)
    a2 = min(abs(val - p2), 0x3FFFFFFF)
    a3 = min(abs(val - p3), 0x3FFFFFFF)
    a4 = min(abs(val - p4), 0x3FFFFFFF)
    a5 = min(abs(val - p5), 0x3FFFFFFF)
    perr[np.uint64(b)] = a0
    perr[np.uint64(b + 1)] = a1
    perr[np.uint64(b + 2)] = a2
    perr[np.uint64(b + 3)] = a3
    perr[np.uint64(b + 4)] = a4
    perr[np.uint64(b + 5)] = a5
    return a0, a1, a2, a3, a4, a5


def workspace(shape: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """The coder's working arrays, fresh (the kernels run without numba's allocator):
    the errors of two slices (the voxel's and the one before, reused slice after slice:
    small enough to stay in cache, unlike one entry per voxel), the contexts' bias sums
    and counts, and the binary models."""
    m = 2 * int(shape[1]) * int(shape[2])
    return (
        np.zeros(m, dtype=np.int64),
        np.zeros(m * PSTRIDE, dtype=np.int32),
        np.zeros(NCTX, dtype=np.int64),
        np.zeros(NCTX, dtype=np.int64),
        np.full(N_MODELS, STATE_INIT, dtype=np.uint16),
    )


@kernel(nrt=False)
def _encode_kernel(v, shape, lo, hi, out, err, perr, bias_sum, bias_cnt, state):
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    cap = out.size
    low, rng, pos = open_encoder(out)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                r = cur + y * nx + x
                pred, ctx, sctx, p0, p1, p2, p3, p4, p5 = _predict_kernel(
                    v, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt
                )
                val = v[np.uint64(i)]
                low, rng, pos = put_residual(
                    out, state, 0, ctx, sctx, val - pred, low, rng, pos, RATE
                )
                _learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, p0, p1, p2, p3, p4, p5)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(data, shape, lo, hi, v, err, perr, bias_sum, bias_cnt, state):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    size = data.size
    code, rng, pos = open_stream(data)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                if pos > size + 4:
                    return 1
                r = cur + y * nx + x
                pred, ctx, sctx, p0, p1, p2, p3, p4, p5 = _predict_kernel(
                    v, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt
                )
                res, code, rng, pos = get_residual(data, state, 0, ctx, sctx, code, rng, pos, RATE)
                if res == NO_RESIDUAL:
                    return 2
                val = pred + res
                if val < lo or val > hi:
                    return 2
                v[np.uint64(i)] = val
                _learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, p0, p1, p2, p3, p4, p5)
                i += 1
    return end_status(data, code, pos)


def checked_input(values: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """A predictive encoder's input as a C-ordered int64 3-D array, once its shape and its
    range ``[lo, hi]`` (at most 2^32 values) are checked."""
    v = np.ascontiguousarray(values, dtype=np.int64)
    if v.ndim != 3:
        raise OptionError(f"expected a 3-D array, found shape {v.shape}")
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise OptionError(f"expected a value range of at most 2^32, found [{lo}, {hi}]")
    return v


def encode(values: np.ndarray, lo: int, hi: int) -> bytes:
    """Code a 3-D integer array whose values lie in ``[lo, hi]`` (a range of at most
    2^32 values, so every residual and weighted sum fits 64 bits)."""
    v = checked_input(values, lo, hi)
    shape = np.array(v.shape, dtype=np.int64)
    flat = v.reshape(-1)
    return encode_with_retry(
        lambda out: _encode_kernel(
            flat, shape, np.int64(lo), np.int64(hi), out, *workspace(v.shape)
        ),
        flat.size,
        (2, 20),
        coder="predictive",
    )


def decode(data: bytes | memoryview, shape: tuple[int, int, int], lo: int, hi: int) -> np.ndarray:
    """Decode :func:`encode`'s bytes into an int64 array of ``shape``."""
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise FormatError(f"predictive payload: value range [{lo}, {hi}] is out of bounds")
    buf = stream_bytes(data, "predictive")
    v = np.empty(int(np.prod(shape)), dtype=np.int64)
    shp = np.array(shape, dtype=np.int64)
    status = _decode_kernel(buf, shp, np.int64(lo), np.int64(hi), v, *workspace(shape))
    check_status(status, "predictive")
    return v.reshape(shape)
