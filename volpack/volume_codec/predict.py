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
from ..entropy.rangecoder import get as _get
from ..entropy.rangecoder import pull as _pull
from ..entropy.rangecoder import push as _push
from ..entropy.rangecoder import put as _put
from ..errors import FormatError, OptionError

NPRED = 6
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
NO_RESIDUAL = np.int64(-(1 << 62))  # get_residual's answer to an impossible length
# Adaptation rates by use count (as rangecoder.RATE, but settling slower: a brick of
# prediction residuals is long and its statistics steady).
RATE = np.array([1, 2, 2, 3, 3, 3, 4, 4, 4, 5, 5, 5, 6, 6, 6, 7], dtype=np.int64)
BIAS_LIMIT = 64  # halve a context's error sum and count when the count reaches this
# 2^24 // t for t < 256: predictor weights without a division (see _weight).
RECIP = np.array([0] + [(1 << 24) // t for t in range(1, 256)], dtype=np.int64)


@kernel(inline=True)
def bitlen(u):
    return 64 - np.int64(leading_zeros(np.uint64(u)))


@kernel(inline=True)
def activity_class(a):
    """Logarithmic class of a non-negative error sum: 0..3 exactly, then two classes
    per power of two, capped at NCTX - 1."""
    if a < 4:
        return a
    b = bitlen(a)
    c = 2 * b - 2 + ((a >> (b - 2)) & 1)
    return min(c, NACT - 1)


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
        q = code // rng
        if q >= (1 << t):  # past the last of the 2^t parts: only damage points there
            return NO_RESIDUAL, code, rng, pos
        code -= q * rng
        u = (u << t) | q
        code, rng, pos = _pull(data, code, rng, pos)
    return (-(u + 1) if neg else u + 1), code, rng, pos


@kernel(inline=True)
def _weight(t):
    """About ``2^24 / t`` for ``t >= 1`` from eight bits of ``t`` (no division); >= 1."""
    if t < 256:
        return RECIP[t]
    sh = bitlen(t) - 8
    return max(RECIP[t >> sh] >> sh, 1)


@kernel(inline=True)
def _edge(err, perr, preds, j, act2):
    """Add the errors of the neighbour ``j`` across an edge: each predictor's to its sum
    in ``preds[NPRED:]``, the final one once to the doubled activity."""
    for k in range(NPRED):
        preds[NPRED + k] += perr[j * NPRED + k]
    return act2 + abs(err[j])


@kernel(inline=True)
def _face(err, perr, preds, j, act2, esum):
    """:func:`_edge` for a face neighbour, which counts twice in the activity and adds
    its final error to the error sum."""
    return _edge(err, perr, preds, j, act2 + abs(err[j])), esum + err[j]


@kernel(inline=True)
def _predict_kernel(v, err, perr, i, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt, preds):
    """Prediction and contexts of voxel ``i`` = (z, y, x) from the decoded ``v``, the
    final errors ``err`` and the per-predictor errors ``perr`` of earlier voxels.

    Returns ``(pred, ctx, sign_ctx)``; fills ``preds`` with the predictors' values.
    """
    sy = nx
    sz = ny * nx
    hw = x > 0
    hn = y > 0
    hu = z > 0
    # Neighbours, with fallbacks that turn each predictor into a lower-dimensional one.
    if hw:
        W = v[i - 1]
    elif hn:
        W = v[i - sy]
    elif hu:
        W = v[i - sz]
    else:
        W = (lo + hi) >> 1
    N = v[i - sy] if hn else W
    U = v[i - sz] if hu else W
    NW = v[i - sy - 1] if hn and hw else N
    NE = v[i - sy + 1] if hn and x + 1 < nx else N
    UW = v[i - sz - 1] if hu and hw else U
    UN = v[i - sz - sy] if hu and hn else U
    UNW = v[i - sz - sy - 1] if hu and hn and hw else UN + UW - U
    preds[0] = W + N - NW
    preds[1] = U + W - UW
    preds[2] = U + N - UN
    preds[3] = W + N + U - NW - UW - UN + UNW
    preds[4] = U
    preds[5] = (W + NE + 1) >> 1
    # Each predictor's error sum at the neighbours, and the activity of the final errors.
    act2 = np.int64(0)  # twice the activity
    esum = np.int64(0)
    for k in range(NPRED):
        preds[NPRED + k] = 0
    if hw:
        act2, esum = _face(err, perr, preds, i - 1, act2, esum)
    if hn:
        act2, esum = _face(err, perr, preds, i - sy, act2, esum)
        if hw:
            act2 = _edge(err, perr, preds, i - sy - 1, act2)
        if x + 1 < nx:
            act2 = _edge(err, perr, preds, i - sy + 1, act2)
    if hu:
        act2, esum = _face(err, perr, preds, i - sz, act2, esum)
    act = act2 >> 1
    # Blend with weights ~ 2^24 / (1 + s_k) (at least 1); the sums stay below 2^63 for
    # a value range below 2^32.
    num = np.int64(0)
    den = np.int64(0)
    for k in range(NPRED):
        w = _weight(preds[NPRED + k] + 1)
        num += w * preds[k]
        den += w
    pred = (num + (den >> 1)) // den
    pmin = preds[0]
    pmax = preds[0]
    for k in range(1, NPRED):
        pmin = min(pmin, preds[k])
        pmax = max(pmax, preds[k])
    spread = pmax - pmin
    # Context: the activity class, split by how far the predictors disagree.
    wide = 0 if 2 * spread <= act else (1 if spread <= 2 * act + 1 else 2)
    ctx = activity_class(act) * NSPREAD + wide
    cnt = bias_cnt[ctx]
    if cnt > 0:  # the context's mean error, rounded, by a reciprocal (cnt < 64)
        s = bias_sum[ctx]
        m = RECIP[cnt]
        pred += (s * m + (1 << 23)) >> 24 if s >= 0 else -((-s * m + (1 << 23)) >> 24)
    if pred < lo:
        pred = lo
    elif pred > hi:
        pred = hi
    sctx = 0 if esum == 0 else (1 if esum > 0 else 2)
    return pred, ctx, sctx


@kernel(inline=True)
def _learn(v, err, perr, i, pred, ctx, bias_sum, bias_cnt, preds):
    """After voxel ``i`` is known: store its errors and update the context's bias."""
    val = v[i]
    e = val - pred
    err[i] = e
    for k in range(NPRED):
        perr[i * NPRED + k] = min(abs(val - preds[k]), 0x3FFFFFFF)
    bias_sum[ctx] += e
    bias_cnt[ctx] += 1
    if bias_cnt[ctx] >= BIAS_LIMIT:
        bias_sum[ctx] = bias_sum[ctx] // 2 if bias_sum[ctx] >= 0 else -((-bias_sum[ctx]) // 2)
        bias_cnt[ctx] >>= 1


@kernel(inline=True)
def _start(n):
    """The state both sides start ``n`` voxels from: final and per-predictor errors, the
    predictions' scratch, the bias sums and counts, the adaptive models."""
    err = np.zeros(n, dtype=np.int64)
    perr = np.zeros(n * NPRED, dtype=np.int32)
    preds = np.zeros(2 * NPRED, dtype=np.int64)
    bias_sum = np.zeros(NCTX, dtype=np.int64)
    bias_cnt = np.zeros(NCTX, dtype=np.int64)
    return err, perr, preds, bias_sum, bias_cnt, np.full(N_MODELS, STATE_INIT, dtype=np.uint16)


@kernel
def _encode_kernel(v, shape, lo, hi, out):
    nz, ny, nx = shape[0], shape[1], shape[2]
    n = nz * ny * nx
    err, perr, preds, bias_sum, bias_cnt, state = _start(n)
    cap = out.size
    low, rng, pos = open_encoder(out)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                pred, ctx, sctx = _predict_kernel(
                    v, err, perr, i, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt, preds
                )
                low, rng, pos = put_residual(
                    out, state, 0, ctx, sctx, v[i] - pred, low, rng, pos, RATE
                )
                _learn(v, err, perr, i, pred, ctx, bias_sum, bias_cnt, preds)
                i += 1
    return finish_stream(out, low, pos)


@kernel
def _decode_kernel(data, shape, lo, hi, v):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    n = nz * ny * nx
    size = data.size
    err, perr, preds, bias_sum, bias_cnt, state = _start(n)
    code, rng, pos = open_stream(data)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos > size + 4:
                    return 1
                pred, ctx, sctx = _predict_kernel(
                    v, err, perr, i, z, y, x, ny, nx, lo, hi, bias_sum, bias_cnt, preds
                )
                r, code, rng, pos = get_residual(data, state, 0, ctx, sctx, code, rng, pos, RATE)
                if r == NO_RESIDUAL:
                    return 2
                val = pred + r
                if val < lo or val > hi:
                    return 2
                v[i] = val
                _learn(v, err, perr, i, pred, ctx, bias_sum, bias_cnt, preds)
                i += 1
    return end_status(data, code, pos)


def encode(values: np.ndarray, lo: int, hi: int) -> bytes:
    """Code a 3-D integer array whose values lie in ``[lo, hi]`` (a range of at most
    2^32 values, so every residual and weighted sum fits 64 bits)."""
    v = np.ascontiguousarray(values, dtype=np.int64)
    if v.ndim != 3:
        raise OptionError(f"expected a 3-D array, found shape {v.shape}")
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise OptionError(f"expected a value range of at most 2^32, found [{lo}, {hi}]")
    shape = np.array(v.shape, dtype=np.int64)
    flat = v.reshape(-1)
    return encode_with_retry(
        lambda out: _encode_kernel(flat, shape, np.int64(lo), np.int64(hi), out),
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
    status = _decode_kernel(buf, np.array(shape, dtype=np.int64), np.int64(lo), np.int64(hi), v)
    check_status(status, "predictive")
    return v.reshape(shape)
