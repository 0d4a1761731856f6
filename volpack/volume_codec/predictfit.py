"""3-D predictive coding, version 2: a least-squares predictor fitted per brick, predictions
in eighths, 16-bit probabilities, and an optional background mask.

Version 1 (:mod:`.predict`) blends six fixed predictors. On noisy scans (MRI) each of
them sees one or three neighbours and passes their noise on; a linear predictor over 16
causal neighbours, fitted to the brick by least squares, averages that noise away
(mean absolute error 1.6 against 2.1 for the best fixed one on the brainsmall MRI). It
replaces the ``U + N - UN`` plane in the blend, which keeps the other five (and the
plane at the brick's faces, where the fit lacks neighbours). The encoder fits one set
of 16 weights per class of the local gradient ``|W-NW| + |N-NW| + |N-NE| + |U-UN| +
|U-UW|`` (4 classes split at the brick's quartiles, or 1), rounds them to 2^-12 and
stores them before the stream.

What else differs from version 1, each measured on the 8-bit MRIs:

- predictions and the bias correction are kept in eighths; the residual is coded
  against the rounded prediction and the eighths left over choose the sign's model
  (a prediction of 10.4 makes a positive residual likelier) and the zero flag's;
- weights ``~ 2^24 / (1 + s)^2`` (the square: the best predictor near the voxel
  counts more), the fixed predictors clipped to the value range;
- probabilities of 16 bits adapting down to ``2^-8`` (12 bits and ``2^-7`` in version
  1 cap a near-certain decision at 0.045 bits, which a flat background pays per voxel);
- the mantissa bits' models split by 8 activity classes instead of 4;
- an optional mask (:mod:`.bgmask`): voxels it marks hold a known value, are skipped,
  and leave no trace in the errors, weights or models.

Values arrive shifted to ``[0, hi]``. The byte layout is in ``formats/lossless-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import end_status, finish_stream, get_bits, open_encoder, open_stream, put_bits
from ..entropy.rangecoder import pull as _pull
from ..entropy.rangecoder import push as _push
from ..errors import FormatError, OptionError
from . import localfit, residmix
from .predict import (
    NCTX,
    NLEN,
    NO_RESIDUAL,
    PSTRIDE,
    RECIP,
    bitlen,
    context,
    floor_div_recip,
    gather,
    interior,
    learn_bias,
    mean_error,
    store_errors,
    workspace,
)
from .residmix import MODEL_INIT, NCAP, NO_MIX, RATE, RATE_MAX  # noqa: F401 (users import them here)
from .residmix import adapted as _adapted

NFRAC = 4  # classes of the prediction's eighths (the sign's context)
# Model layout: zero flags (2 per context), signs (3 x NFRAC per context), unary bit
# lengths, mantissa bits (16 activity groups).
M_ZERO = 0
M_SIGN = M_ZERO + NCTX * 2
M_LEN = M_SIGN + NCTX * 3 * NFRAC
M_MANT = M_LEN + NCTX * NLEN
N_MODELS = M_MANT + NLEN * 4 * 16
# Low-value models (the payload's LOW flag): a voxel predicted below NLOW codes its zero
# flag, sign and lengths in models keyed on the prediction itself rather than on the
# activity, and its lengths apart by sign. Near the bottom of a brick's range the values'
# histogram is far from a residual's smooth shape (the noise floor of a magnitude image:
# on the brainsmall MRI 0 and 2 are each six times as common as 1), and a model of the
# residual given the prediction learns it; the mantissa bits keep their models.
NLOW = 16
M_LOWZ = N_MODELS
M_LOWS = M_LOWZ + NLOW * NFRAC
M_LOWL = M_LOWS + NLOW * 3 * NFRAC
N_MODELS_LOW = M_LOWL + NLOW * 2 * NLEN
# Low-value mantissa models (the payload's LOWM flag, with LOW): a voxel of the low-value
# class also codes up to three bits below the leading one in models keyed on the
# prediction, the sign and the bit length (up to NLOWB - 1), not on the activity. On
# noise at the bottom of the range (a uint8 scan's iid noise floor), the value given the
# prediction is bounded by the range: the activity's models and the bits at one half
# spent 0.07-0.09 bits a voxel there (results/lossless/noise39/trace.txt). Flagged to the
# kernels as LOW_MANT in ``nlow``; the class ``q`` of such a voxel is NLOW + prediction.
LOW_MANT = 1 << 8
NLOWB = 8
M_LOWM = N_MODELS_LOW
N_MODELS_LOWM = M_LOWM + NLOW * 2 * NLOWB * 8
# Texture bias (the payload's TEX flag): the bias correction kept per context of the
# activity (NCTX / NTEXG groups) and the texture, whether each of W, N, U, NE, NW and UN
# lies above the blend (CALIC's error feedback: -0.4 to -1.0 % of the residuals' bits on
# the noisy MRIs, where the bias per coding context alone leaves the sign near a coin
# toss); and the activity of the contexts also counts the local gradient (CALIC's
# energy estimate, errors and gradients: -0.3 to -0.4 % more).
NTEX = 64
NTEXG = 12
NBIAS = NCTX + (NCTX // NTEXG) * NTEX
CF_BITS = 12  # fixed-point bits of the fitted weights
CF_LIMIT = (1 << 15) - 1
NCLS = 4  # gradient classes of the fitted predictor
NO_CLASS = 0xFFFFFFFF  # threshold of an unused class
HANDOVER = -1  # a test's lever: the row from which _decode_plain hands over (-1: none)
# The fitted predictor's neighbours as (dz, dy, dx) steps back (the order of _fitted).
FIT_OFFSETS = (
    (0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (1, 0, 1), (1, 1, 0), (1, 1, 1),
    (0, 0, 2), (0, 2, 0), (2, 0, 0), (1, 0, -1), (1, -1, 0), (1, 1, -1), (1, -1, 1), (1, -1, -1),
)  # fmt: skip
NFIT = len(FIT_OFFSETS)
# The planar predictor (the payload's PLANE flag): the brick's slices coded as one plane,
# stacked along y, with NFIT weights on these in-plane neighbours as (dy, dx) steps back
# (the order of _fitted_plane). A few thick slices (resampled CT) or one slice have little
# to gain along z: the 3-D fit needs two slices before a voxel (none in a 1-slice brick,
# whose voxels all took the fallback blend), the planar one three rows and three columns.
PLANE_OFFSETS = (
    (0, 1), (1, 0), (1, 1), (1, -1), (0, 2), (2, 0), (1, 2), (1, -2),
    (2, 1), (2, -1), (2, 2), (2, -2), (0, 3), (3, 0), (1, 3), (1, -3),
)  # fmt: skip
PLANE_REACH = 3
# The local fit's weight against the blend (in 16ths) follows the two estimates' mean
# absolute errors in the coding context, squared (as the weights of two estimates with
# independent errors go); both sums halve past LOCAL_LIMIT (eighths).
LOCAL_LIMIT = 8192
HEAD = 4 * (NCLS - 1) + 2 * NCLS * NFIT  # thresholds and weights before the stream


@kernel(inline=True)
def _adapt(models, k, p, n, mask):
    """:func:`_adapted`, stored back into model ``k``."""
    models[np.uint64(k)] = _adapted(p, n, mask)


@kernel(inline=True)
def put16(out, models, k, bit, low, rng, pos):
    """Code one decision with the 16-bit adaptive model ``models[k]`` (the range coder
    of :mod:`volpack.entropy.rangecoder`, its probability split at 16 bits)."""
    st = np.int64(models[np.uint64(k)])
    p = st >> 8
    bound = (rng >> 16) * p
    mask = -np.int64(bit)
    low += bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    _adapt(models, k, p, st & 255, mask)
    return _push(out, low, rng, pos)


@kernel(inline=True)
def get16_held(data, st, code, rng, pos):
    """Decode one decision coded by :func:`put16` with the model's state ``st`` held by
    the caller; returns ``(bit, new state, code, rng, pos)``."""
    p = st >> 8
    bound = (rng >> 16) * p
    bit = np.int64(code >= bound)
    mask = -bit
    code -= bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    code, rng, pos = _pull(data, code, rng, pos)
    return bit, _adapted(p, st & 255, mask), code, rng, pos


@kernel(inline=True)
def get16(data, models, k, code, rng, pos):
    """Decode one decision coded by :func:`put16`; returns ``(bit, code, rng, pos)``."""
    bit, models[np.uint64(k)], code, rng, pos = get16_held(
        data, np.int64(models[np.uint64(k)]), code, rng, pos
    )
    return bit, code, rng, pos


@kernel(inline=True)
def _put16m(out, models, k, bit, low, rng, pos, aux, mx, slot, kind):
    """:func:`put16`, or with ``MIX`` (``mx`` from :func:`.residmix.contexts`) the
    decision coded with the mix of model ``k`` and models 2-4 at ``slot`` (weights of
    decision ``kind``); model ``k`` adapts as in :func:`put16` either way."""
    st = np.int64(models[np.uint64(k)])
    p1 = st >> 8
    if not residmix.mixing(mx, p1):
        return put16(out, models, k, bit, low, rng, pos)
    mask = -np.int64(bit)
    p, held = residmix.mix(p1, aux, mx, slot, kind)
    bound = (rng >> 16) * p
    low += bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    _adapt(models, k, p1, st & 255, mask)
    residmix.learn(aux, mx, slot, p, held, mask, True)
    return _push(out, low, rng, pos)


@kernel(inline=True)
def _get16m_held(data, st, code, rng, pos, aux, mx, slot, kind, clamp):
    """Decode one decision coded by :func:`_put16m` (model 1's state ``st`` held by the
    caller; ``clamp`` as :func:`.residmix.learn`); returns ``(bit, model 1's new state,
    code, rng, pos)``."""
    p1 = st >> 8
    if not residmix.mixing(mx, p1):
        return get16_held(data, st, code, rng, pos)
    p, held = residmix.mix(p1, aux, mx, slot, kind)
    bound = (rng >> 16) * p
    bit = np.int64(code >= bound)
    mask = -bit
    code -= bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    code, rng, pos = _pull(data, code, rng, pos)
    residmix.learn(aux, mx, slot, p, held, mask, clamp)
    return bit, _adapted(p1, st & 255, mask), code, rng, pos


@kernel(inline=True)
def _get16m(data, models, k, code, rng, pos, aux, mx, slot, kind, clamp):
    bit, models[np.uint64(k)], code, rng, pos = _get16m_held(
        data, np.int64(models[np.uint64(k)]), code, rng, pos, aux, mx, slot, kind, clamp
    )
    return bit, code, rng, pos


@kernel(inline=True)
def _near_half(sctx):
    """1 when the prediction's eighths (in ``sctx``) lie near a half, else 0."""
    return ((sctx & (NFRAC - 1)) + 1) >> 1 & 1


@kernel(inline=True)
def _zero_model(ctx, sctx):
    """Zero flag's model: the context, and whether the prediction lies near a half."""
    return M_ZERO + 2 * ctx + _near_half(sctx)


@kernel(inline=True)
def _mant_model(nb, prefix, ctx):
    return M_MANT + ((nb * 4 + prefix) << 4) + min(ctx // 6, 15)


@kernel(inline=True)
def _mant_model_q(nb, prefix, ctx, q, neg):
    """Mantissa bit's model: :func:`_mant_model`, or by the low-value class ``q``
    (LOW_MANT), the sign and the length."""
    if q < NLOW:
        return _mant_model(nb, prefix, ctx)
    return M_LOWM + ((((q - NLOW) * 2 + neg) * NLOWB + min(nb, NLOWB - 1)) << 3) + prefix


@kernel(inline=True)
def _mant_bits(nb, q):
    """How many bits below the leading one are modelled: 2, 3 in the LOW_MANT class."""
    return min(nb - 1, 2 + np.int64(q >= NLOW))


@kernel(inline=True)
def _low_class(pred, nlow):
    """The low-value class of a prediction: itself below ``nlow`` (its low byte), plus
    NLOW with LOW_MANT, else -1 (none)."""
    if pred < (nlow & (LOW_MANT - 1)):
        return pred + (NLOW if nlow & LOW_MANT else 0)
    return np.int64(-1)


@kernel(inline=True)
def _sign_model(ctx, sctx, q):
    """Sign's model: by the context, or by the low-value class ``q`` when there is one."""
    if q < 0:
        return M_SIGN + ctx * 3 * NFRAC + sctx
    return M_LOWS + (q & (NLOW - 1)) * 3 * NFRAC + sctx


@kernel(inline=True)
def _len_models(ctx, q, neg):
    """First of the lengths' models: by the context, or by the low-value class ``q``
    and the sign."""
    if q < 0:
        return M_LEN + ctx * NLEN
    return M_LOWL + (2 * (q & (NLOW - 1)) + neg) * NLEN


@kernel(inline=True)
def _zero_model_q(ctx, sctx, q):
    """Zero flag's model: :func:`_zero_model`, or by the low-value class ``q``."""
    return _zero_model(ctx, sctx) if q < 0 else M_LOWZ + (q & (NLOW - 1)) * NFRAC + (sctx & (NFRAC - 1))


@kernel(inline=True)
def _zero_state(models, ctx, sctx, q):
    """The zero flag's model and its state. Both of the context's zero-flag models are
    loaded, then one picked by the prediction's eighths: the loads wait for the context
    only, not for the prediction, which comes last (out of the division)."""
    kz = M_ZERO + 2 * ctx
    st0 = np.int64(models[np.uint64(kz)])
    st1 = np.int64(models[np.uint64(kz + 1)])
    h = _near_half(sctx)
    kz += h
    st = st0 + ((st1 - st0) & -h)
    if q >= 0:
        kz = M_LOWZ + (q & (NLOW - 1)) * NFRAC + (sctx & (NFRAC - 1))
        st = np.int64(models[np.uint64(kz)])
    return kz, st


@kernel(inline=True)
def _low_bits(data, u, nb, nm, neg, code, rng, pos):
    """The residual from its decoded leading bits ``u``: the bits at one half, the sign."""
    # (a damaged low part moves pos past the end: the end check refuses the stream)
    w, code, rng, pos = get_bits(data, np.uint64(u), nb - 1 - max(nm, 0), code, rng, pos)
    u = np.int64(w)
    return (-(u + 1) if neg else u + 1), code, rng, pos


# put_residual and get_residual code without the mix (the lossy path's adaptive bins
# use them too): written apart from the mixed pair below, whose dead code took the
# lossy kernels 3-7 s more each to compile even with the mix pruned (measured).
@kernel(inline=True)
def put_residual(out, models, ctx, sctx, q, r, low, rng, pos):
    """Code residual ``r`` as :func:`.predict.put_residual` does (zero flag, sign, unary
    bit length of ``|r| - 1``, two bits below its leading one, the rest at one half),
    with this module's models (the low-value ones for class ``q >= 0``)."""
    kz = _zero_model_q(ctx, sctx, q)
    low, rng, pos = put16(out, models, kz, np.int64(r != 0), low, rng, pos)
    if r == 0:
        return low, rng, pos
    neg = np.int64(r < 0)
    low, rng, pos = put16(out, models, _sign_model(ctx, sctx, q), neg, low, rng, pos)
    u = abs(r) - 1
    nb = bitlen(u)
    k0 = _len_models(ctx, q, neg)
    for j in range(min(nb + 1, NLEN - 1)):
        low, rng, pos = put16(out, models, k0 + j, np.int64(nb > j), low, rng, pos)
    nm = _mant_bits(nb, q)
    prefix = 1
    for jm in range(nm):
        bit = (u >> (nb - 2 - jm)) & 1
        low, rng, pos = put16(out, models, _mant_model_q(nb, prefix, ctx, q, neg), bit, low, rng, pos)
        prefix = 2 * prefix + bit
    return put_bits(out, np.uint64(u), nb - 1 - max(nm, 0), low, rng, pos)


@kernel(inline=True)
def get_residual(data, models, ctx, sctx, q, code, rng, pos):
    """Decode what :func:`put_residual` coded; ``NO_RESIDUAL`` for an impossible one."""
    kz, st = _zero_state(models, ctx, sctx, q)
    bit, models[np.uint64(kz)], code, rng, pos = get16_held(data, st, code, rng, pos)
    if bit == 0:
        return np.int64(0), code, rng, pos
    neg, code, rng, pos = get16(data, models, _sign_model(ctx, sctx, q), code, rng, pos)
    k0 = _len_models(ctx, q, neg)
    nb = 0
    while nb < NLEN - 1:
        bit, code, rng, pos = get16(data, models, k0 + nb, code, rng, pos)
        if bit == 0:
            break
        nb += 1
    if nb > 62:
        return NO_RESIDUAL, code, rng, pos
    u = np.int64(1 if nb >= 1 else 0)
    nm = _mant_bits(nb, q)
    prefix = 1
    for _ in range(nm):
        bit, code, rng, pos = get16(data, models, _mant_model_q(nb, prefix, ctx, q, neg), code, rng, pos)
        prefix = 2 * prefix + bit
        u = (u << 1) | bit
    return _low_bits(data, u, nb, nm, neg, code, rng, pos)


@kernel(inline=True)
def put_residual_mix(out, models, ctx, sctx, q, r, low, rng, pos, aux, mx):
    """:func:`put_residual`, each decision mixed with models 2-4 of ``aux`` at the slots
    ``mx`` (:func:`.residmix.contexts`; ``NO_MIX``: not mixed)."""
    kz = _zero_model_q(ctx, sctx, q)
    sz = residmix.S_ZERO + (sctx & (NFRAC - 1))
    low, rng, pos = _put16m(out, models, kz, np.int64(r != 0), low, rng, pos, aux, mx, sz, 0)
    if r == 0:
        return low, rng, pos
    neg = np.int64(r < 0)
    ks = _sign_model(ctx, sctx, q)
    low, rng, pos = _put16m(out, models, ks, neg, low, rng, pos, aux, mx, residmix.S_SIGN + sctx, 1)
    u = abs(r) - 1
    nb = bitlen(u)
    k0 = _len_models(ctx, q, neg)
    for j in range(min(nb + 1, NLEN - 1)):
        sl, kind = _len_slot(j)
        low, rng, pos = _put16m(out, models, k0 + j, np.int64(nb > j), low, rng, pos, aux, mx, sl, kind)
    nm = _mant_bits(nb, q)
    prefix = 1
    for jm in range(nm):
        bit = (u >> (nb - 2 - jm)) & 1
        km = _mant_model_q(nb, prefix, ctx, q, neg)
        sl = _mant_slot(nb, prefix)
        low, rng, pos = _put16m(out, models, km, bit, low, rng, pos, aux, mx, sl, 14 + min(jm, 1))
        prefix = 2 * prefix + bit
    return put_bits(out, np.uint64(u), nb - 1 - max(nm, 0), low, rng, pos)


@kernel(inline=True)
def _len_slot(j):
    """Models 2-4's slot and the weights' kind of length bit ``j``."""
    return residmix.S_LEN + min(j, residmix.NLENS - 1), 2 + min(j, 11)


@kernel(inline=True)
def _mant_slot(nb, prefix):
    return residmix.S_MANT + 4 * min(nb, 15) + (prefix & 3)  # (a third bit's prefix 4-7: 0-3)


@kernel(inline=True)
def get_residual_mix(data, models, ctx, sctx, q, code, rng, pos, aux, mx, clamp):
    """Decode what :func:`put_residual_mix` coded; ``NO_RESIDUAL`` for an impossible one
    (``clamp``: as :func:`.residmix.learn`)."""
    kz, st = _zero_state(models, ctx, sctx, q)
    sz = residmix.S_ZERO + (sctx & (NFRAC - 1))
    bit, models[np.uint64(kz)], code, rng, pos = _get16m_held(data, st, code, rng, pos, aux, mx, sz, 0, clamp)
    if bit == 0:
        return np.int64(0), code, rng, pos
    ks = _sign_model(ctx, sctx, q)
    neg, code, rng, pos = _get16m(
        data, models, ks, code, rng, pos, aux, mx, residmix.S_SIGN + sctx, 1, clamp
    )
    k0 = _len_models(ctx, q, neg)
    nb = 0
    while nb < NLEN - 1:
        sl, kind = _len_slot(nb)
        bit, code, rng, pos = _get16m(data, models, k0 + nb, code, rng, pos, aux, mx, sl, kind, clamp)
        if bit == 0:
            break
        nb += 1
    if nb > 62:
        return NO_RESIDUAL, code, rng, pos
    u = np.int64(1 if nb >= 1 else 0)
    nm = _mant_bits(nb, q)
    prefix = 1
    for jm in range(nm):
        km = _mant_model_q(nb, prefix, ctx, q, neg)
        sl = _mant_slot(nb, prefix)
        bit, code, rng, pos = _get16m(data, models, km, code, rng, pos, aux, mx, sl, 14 + min(jm, 1), clamp)
        prefix = 2 * prefix + bit
        u = (u << 1) | bit
    return _low_bits(data, u, nb, nm, neg, code, rng, pos)


def _weight2_table() -> np.ndarray:
    """``_weight2`` for every ``s`` below W2_SPAN, from the definition: ``w = 2^24 / t``
    from eight bits of ``t = s + 1`` (:func:`.predict.weight`), then ``max(w^2 >> 24, 1)``.
    From ``t = 2^13`` on, ``w < 2^12`` and the weight is 1."""
    t = np.arange(1, W2_SPAN + 1, dtype=np.int64)
    sh = np.maximum(np.floor(np.log2(t)).astype(np.int64) + 1 - 8, 0)
    w = np.maximum(RECIP[t >> sh] >> sh, 1)
    return np.maximum((w * w) >> 24, 1).astype(np.uint32)


W2_SPAN = 1 << 13
W2 = _weight2_table()


@kernel(inline=True)
def _weight2(s):
    """``~ 2^24 / (1 + s)^2``, at least 1: one load (the arithmetic of
    :func:`.predict.weight` and the square took a sixth of the decoder's time)."""
    return np.int64(W2[np.uint64(min(s, W2_SPAN - 1))])


@kernel(inline=True)
def _fitted(v, cf, c, i, sy, sz):
    """The fitted predictor with the weights ``cf[c:c + 16]``, in eighths."""
    t = (
        cf[np.uint64(c)] * v[np.uint64(i - 1)]
        + cf[np.uint64(c + 1)] * v[np.uint64(i - sy)]
        + cf[np.uint64(c + 2)] * v[np.uint64(i - sz)]
        + cf[np.uint64(c + 3)] * v[np.uint64(i - sy - 1)]
        + cf[np.uint64(c + 4)] * v[np.uint64(i - sy + 1)]
        + cf[np.uint64(c + 5)] * v[np.uint64(i - sz - 1)]
        + cf[np.uint64(c + 6)] * v[np.uint64(i - sz - sy)]
        + cf[np.uint64(c + 7)] * v[np.uint64(i - sz - sy - 1)]
        + cf[np.uint64(c + 8)] * v[np.uint64(i - 2)]
        + cf[np.uint64(c + 9)] * v[np.uint64(i - 2 * sy)]
        + cf[np.uint64(c + 10)] * v[np.uint64(i - 2 * sz)]
        + cf[np.uint64(c + 11)] * v[np.uint64(i - sz + 1)]
        + cf[np.uint64(c + 12)] * v[np.uint64(i - sz + sy)]
        + cf[np.uint64(c + 13)] * v[np.uint64(i - sz - sy + 1)]
        + cf[np.uint64(c + 14)] * v[np.uint64(i - sz + sy - 1)]
        + cf[np.uint64(c + 15)] * v[np.uint64(i - sz + sy + 1)]
    )
    return (t + (1 << (CF_BITS - 4))) >> (CF_BITS - 3)


@kernel(inline=True)
def _fitted_plane(v, cf, c, i, sy):
    """The planar predictor with the weights ``cf[c:c + 16]`` (:data:`PLANE_OFFSETS`), in
    eighths."""
    t = (
        cf[np.uint64(c)] * v[np.uint64(i - 1)]
        + cf[np.uint64(c + 1)] * v[np.uint64(i - sy)]
        + cf[np.uint64(c + 2)] * v[np.uint64(i - sy - 1)]
        + cf[np.uint64(c + 3)] * v[np.uint64(i - sy + 1)]
        + cf[np.uint64(c + 4)] * v[np.uint64(i - 2)]
        + cf[np.uint64(c + 5)] * v[np.uint64(i - 2 * sy)]
        + cf[np.uint64(c + 6)] * v[np.uint64(i - sy - 2)]
        + cf[np.uint64(c + 7)] * v[np.uint64(i - sy + 2)]
        + cf[np.uint64(c + 8)] * v[np.uint64(i - 2 * sy - 1)]
        + cf[np.uint64(c + 9)] * v[np.uint64(i - 2 * sy + 1)]
        + cf[np.uint64(c + 10)] * v[np.uint64(i - 2 * sy - 2)]
        + cf[np.uint64(c + 11)] * v[np.uint64(i - 2 * sy + 2)]
        + cf[np.uint64(c + 12)] * v[np.uint64(i - 3)]
        + cf[np.uint64(c + 13)] * v[np.uint64(i - 3 * sy)]
        + cf[np.uint64(c + 14)] * v[np.uint64(i - sy - 3)]
        + cf[np.uint64(c + 15)] * v[np.uint64(i - sy + 3)]
    )
    return (t + (1 << (CF_BITS - 4))) >> (CF_BITS - 3)


@kernel(inline=True)
def _gather(v, err, perr, i, r, ru, z, y, x, ny, nx, hi, held):
    """:func:`.predict.gather`, with what the voxel before left (``held``: its value,
    its error and its predictors' errors, see :func:`_learn`) taken from registers
    inside the brick rather than read back from the arrays it was just stored in:
    that store and load were on the decoder's one chain, from a voxel to the next."""
    if not (x > 0 and y > 0 and z > 0 and x + 1 < nx):
        return gather(v, err, perr, i, r, ru, z, y, x, ny, nx, 0, hi)
    W, eW, a0, a1, a2, a3, a4, a5 = held
    return interior(v, err, perr, i, r, ru, nx, ny * nx, W, eW, a0, a1, a2, a3, a4, a5)


@kernel(inline=True)
def _texture_bias(ctx, p0, W, N, U, NE, NW, UN):
    """The bias slot of a voxel coded with the texture bias: its activity group and which
    of six neighbours lie above the blend ``p0`` (in eighths)."""
    t = (
        np.int64(8 * W > p0)
        + 2 * np.int64(8 * N > p0)
        + 4 * np.int64(8 * U > p0)
        + 8 * np.int64(8 * NE > p0)
        + 16 * np.int64(8 * NW > p0)
        + 32 * np.int64(8 * UN > p0)
    )
    return NCTX + (ctx // NTEXG) * NTEX + t


@kernel(inline=True)
def _predict_kernel(v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, bias, held, tex, plane, lpe, lw):
    """Prediction and contexts of voxel ``i`` = (z, y, x) from the decoded ``v`` (values
    in ``[0, hi]``), the errors of earlier voxels (as :func:`.predict.gather`; ``held``
    as :func:`_gather`) and the mean errors ``bias`` (kept by :func:`_learn`): of the
    coding context, or with ``tex`` of the texture (:func:`_texture_bias`). The blend
    is averaged with the local fit's estimate ``lpe`` (:mod:`.localfit`, in eighths)
    unless that is ``localfit.NONE``, weighted by the two's errors in the context
    (``lw``, kept by :func:`_learn_local`). With ``plane`` (a brick coded as one slice)
    the fitted predictor is :func:`_fitted_plane`, its class by in-plane gradients.

    Returns ``(pred, ctx, bias slot, sign_ctx, activity, q0, ..., q5, blend, local fit)``
    (the six predictors, the blend and the clipped local fit in eighths).
    """
    W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5 = _gather(
        v, err, perr, i, r, ru, z, y, x, ny, nx, hi, held
    )
    h8 = 8 * hi
    q0 = min(max(8 * (W + N - NW), 0), h8)
    q1 = min(max(8 * (U + W - UW), 0), h8)
    if z >= 2 and y >= 2 and x >= 2 and x + 1 < nx and y + 1 < ny:
        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
        c = (np.int64(g > th[0]) + np.int64(g > th[1]) + np.int64(g > th[2])) * NFIT
        q2 = min(max(_fitted(v, cf, c, i, nx, ny * nx), 0), h8)
    elif plane and y >= PLANE_REACH and x >= PLANE_REACH and x + PLANE_REACH < nx:
        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(W - v[np.uint64(i - 2)]) + abs(N - v[np.uint64(i - 2 * nx)])
        c = (np.int64(g > th[0]) + np.int64(g > th[1]) + np.int64(g > th[2])) * NFIT
        q2 = min(max(_fitted_plane(v, cf, c, i, nx), 0), h8)
    else:
        q2 = min(max(8 * (U + N - UN), 0), h8)
    q3 = min(max(8 * (W + N + U - NW - UW - UN + UNW), 0), h8)
    q4 = 8 * U
    q5 = 4 * (W + NE)
    if plane:  # (U is W in a plane: its slots take in-plane predictors)
        q1 = 8 * N
        q3 = min(max(8 * (W + NE - N), 0), h8)
        q4 = 8 * NE
    if tex:
        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
        act = (act2 + g) >> 1
    else:
        act = act2 >> 1
    # Blend; the predictions lie in [0, 8 hi] (below 2^35) and the weights below 2^25,
    # so the sums stay below 2^63.
    w0 = _weight2(s0)
    w1 = _weight2(s1)
    w2 = _weight2(s2)
    w3 = _weight2(s3)
    w4 = _weight2(s4)
    w5 = _weight2(s5)
    den = w0 + w1 + w2 + w3 + w4 + w5
    # The reciprocal waits for the weights only (the voxel before's errors), not for the
    # fitted predictor: the division is off the chain, a multiply is left on it.
    rden = 1.0 / np.float64(den)
    num = w0 * q0 + w1 * q1 + w2 * q2 + w3 * q3 + w4 * q4 + w5 * q5
    ctx = context(act, (max(q0, q1, q2, q3, q4, q5) - min(q0, q1, q2, q3, q4, q5)) >> 3)
    # (num >= 0: the predictions are clipped to [0, 8 hi] and the weights are positive)
    p0 = floor_div_recip(num + (den >> 1), den, rden)
    pb = p0
    lq = localfit.NONE
    if lpe != localfit.NONE:
        lq = min(max(lpe, 0), h8)
        eb = lw[np.uint64(2 * ctx)]
        el = lw[np.uint64(2 * ctx + 1)]
        eb *= eb  # (below 2^47: the sums stay below LOCAL_LIMIT + 8 * 2^20)
        el *= el
        k = (16 * eb + ((eb + el) >> 1)) // (eb + el) if eb + el > 0 else 8
        p0 = (p0 * (16 - k) + lq * k + 8) >> 4
    bctx = _texture_bias(ctx, p0, W, N, U, NE, NW, UN) if tex else ctx
    p8 = min(max(p0 + bias[np.uint64(bctx)], 0), h8)
    pred = (p8 + 4) >> 3
    frac = p8 - 8 * pred  # -4..3
    sctx = (np.int64(esum > 0) + 2 * np.int64(esum < 0)) * NFRAC + ((frac + 4) >> 1)
    return pred, ctx, bctx, sctx, act, q0, q1, q2, q3, q4, q5, pb, lq


@kernel(inline=True)
def _learn_local(lw, ctx, val, pb, lq):
    """After voxel ``val`` is known: add the blend's (``pb``) and the local fit's
    (``lq``, unless ``localfit.NONE``) absolute errors to the context's sums."""
    if lq != localfit.NONE:
        eb = lw[np.uint64(2 * ctx)] + abs(8 * val - pb)
        el = lw[np.uint64(2 * ctx + 1)] + abs(8 * val - lq)
        if eb + el > LOCAL_LIMIT:
            eb >>= 1
            el >>= 1
        lw[np.uint64(2 * ctx)] = eb
        lw[np.uint64(2 * ctx + 1)] = el


@kernel(inline=True)
def _predict_mix(v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, bias, held, tex, plane, mix, lpe, lw):
    """:func:`_predict_kernel`, with the voxel's slots of the mixed estimates
    (:func:`.residmix.contexts`, or ``NO_MIX``) in place of the activity."""
    pred, ctx, bctx, sctx, act, q0, q1, q2, q3, q4, q5, pb, lq = _predict_kernel(
        v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, bias, held, tex, plane, lpe, lw
    )
    mx = NO_MIX
    if mix:
        mx = residmix.contexts(err, r, ru, y, x, ny, nx, act, ctx, pred)
    return pred, ctx, bctx, sctx, mx, q0, q1, q2, q3, q4, q5, pb, lq


@kernel(inline=True)
def _learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5):
    """After voxel ``val`` at ring slot ``r`` is known: store its errors (the
    predictors' in eighths) and update the context's bias (in eighths). The bias the
    next voxel adds is stored ready (``bias``): worked out here from the new sum and
    count, it is not on the path from one voxel's context to the next one's prediction
    (two dependent loads and a multiply there cost the decoder a fifth of its time).
    Returns what the next voxel holds of this one (:func:`_gather`)."""
    e = val - pred
    a0, a1, a2, a3, a4, a5 = store_errors(err, perr, r, e, 8 * val, q0, q1, q2, q3, q4, q5)
    s, c = learn_bias(bias_sum, bias_cnt, ctx, 8 * e)
    bias[np.uint64(ctx)] = mean_error(s, c)
    return val, e, a0, a1, a2, a3, a4, a5


@kernel(inline=True)
def _skip(err, perr, r, val):
    """A masked voxel (of value ``val``): no error anywhere. Returns what the next
    voxel holds of it (:func:`_gather`)."""
    err[np.uint64(r)] = 0
    b = r * PSTRIDE
    for k in range(6):
        perr[np.uint64(b + k)] = 0
    z = np.int64(0)
    return val, z, z, z, z, z, z, z


def _workspace(shape: tuple[int, ...]) -> tuple[np.ndarray, ...]:
    """:func:`.predict.workspace`'s ring arrays, the bias slots' error sums, counts and
    means (0 before any error: a sum and a count of 0 mean 0; the coding contexts', then
    the texture bias's), this module's models and the mix's (:func:`.residmix.workspace`).
    Then the local fit's error sums per context (:func:`_learn_local`; its sums and
    system are the decoder's alone: the encoder is handed the estimates)."""
    err, perr, _, _, _ = workspace(shape)
    bias_sum, bias = (np.zeros(NBIAS, dtype=np.int64) for _ in range(2))
    bias_cnt = np.zeros(NBIAS, dtype=np.uint8)  # (below BIAS_LIMIT, 64: a cache line holds 64)
    models = np.full(N_MODELS_LOWM, MODEL_INIT, dtype=np.uint32)
    return err, perr, bias_sum, bias_cnt, bias, models, residmix.workspace(), np.zeros(2 * NCTX, np.int64)


@kernel(nrt=False)
def _encode_kernel(
    v, mk, cf, th, shape, hi, nlow, tex, plane, mix, lp, ls, out, err, perr, bias_sum, bias_cnt, bias,
    models, aux, lw,
):
    """``lp``: the local fit's estimate of every voxel (:func:`.localfit.estimates`),
    used when ``ls``."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    cap = out.size
    low, rng, pos = open_encoder(out)
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                r = cur + y * nx + x
                if mk[np.uint64(i)]:
                    held = _skip(err, perr, r, v[np.uint64(i)])
                    i += 1
                    continue
                lpe = lp[np.uint64(i)] if ls else localfit.NONE
                pred, ctx, bctx, sctx, mx, q0, q1, q2, q3, q4, q5, pb, lq = _predict_mix(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held, tex, plane,
                    mix, lpe, lw,
                )
                val = v[np.uint64(i)]
                q = _low_class(pred, nlow)
                low, rng, pos = put_residual_mix(
                    out, models, ctx, sctx, q, val - pred, low, rng, pos, aux, mx
                )
                held = _learn(
                    err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5
                )
                _learn_local(lw, ctx, val, pb, lq)
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(
    data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, ls, st, cs, ws, a, g, v, err, perr,
    bias_sum, bias_cnt, bias, models, aux, lw, start, coder,
):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible value, 3 when
    it does not end where its length says. With ``ls``, the local fit's sums are moved
    along at every voxel of its region (coded or masked), its weights fitted where
    :func:`.localfit.refits` and its estimate made at the coded voxels (``st``, ``cs``,
    ``ws``, ``a``, ``g``: :mod:`.localfit`'s steps and workspace). From row ``start``
    (of the whole brick, ``z * ny + y``) on, with the coder's state ``coder[:3]``, where
    :func:`_decode_plain` stopped (0: from the stream's start)."""
    return _decode_rows(
        data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, ls, st, cs, ws, a, g, v, err, perr,
        bias_sum, bias_cnt, bias, models, aux, lw, start, -1, coder, False,
    )  # fmt: skip


@kernel(nrt=False)
def _decode_plain(
    data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, st, cs, ws, a, g, v, err, perr, bias_sum,
    bias_cnt, bias, models, aux, lw, stop, coder,
):
    """:func:`_decode_kernel` without the local fit (every stream but those flagged with
    it: its tests compile out) and without the mix's bound on its weights, rows at a
    time while :func:`.residmix.room` says the bound cannot act on them (always, in
    practice: the weights stay far inside it). Where it could, returns 4 with the
    coder's state and the row to go on from in ``coder``, for :func:`_decode_kernel` to
    finish; also at row ``stop`` (a test's lever)."""
    return _decode_rows(
        data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, False, st, cs, ws, a, g, v, err, perr,
        bias_sum, bias_cnt, bias, models, aux, lw, 0, stop, coder, True,
    )  # fmt: skip


@kernel(inline=True)
def _decode_rows(
    data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, ls, st, cs, ws, a, g, v, err, perr,
    bias_sum, bias_cnt, bias, models, aux, lw, start, stop, coder, fast,
):
    """The two kernels' loop; ``fast`` (a constant): :func:`_decode_plain`'s."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    size = data.size
    code, rng, pos = open_stream(data)
    if start > 0:
        code, rng, pos = coder[0], coder[1], coder[2]
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)  # (not read at a row's first voxel)
    i = start * nx
    left = np.int64(0)  # voxels to go before the weights could come near their bound
    for z in range(start // ny, nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(start % ny if z == start // ny else 0, ny):
            if fast:
                if left < nx:
                    left = residmix.room(aux)
                if left < nx or z * ny + y == stop:
                    coder[0], coder[1], coder[2], coder[3] = code, rng, pos, z * ny + y
                    return 4
                left -= nx
            fits = ls and z >= 2
            if fits:
                localfit.row_start(cs, v, z, y, ny, nx, st, g)
            fits = fits and 2 <= y <= ny - 2
            fitted = False
            for x in range(nx):
                if pos > size + 4:
                    return 1
                r = cur + y * nx + x
                here = fits and 2 <= x <= nx - 2
                if here:
                    localfit.advance(cs, ws, v, i, x, nx, st, g)
                    if localfit.refits(x):  # (not for two masked voxels: no use)
                        fitted = (mk[np.uint64(i)] == 0 or (x < nx - 2 and mk[np.uint64(i + 1)] == 0))
                        fitted = fitted and localfit.solve(ws, a)
                if mk[np.uint64(i)]:
                    v[np.uint64(i)] = fill
                    held = _skip(err, perr, r, fill)
                    i += 1
                    continue
                lpe = localfit.estimate(a, v, i, st) if here and fitted else localfit.NONE
                bad, held, code, rng, pos = _decode_voxel(
                    data, v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, nlow, bias,
                    bias_sum, bias_cnt, held, (tex, plane), mix, lpe, lw, models, aux, code, rng, pos, not fast,
                )  # fmt: skip
                if bad:
                    return 2
                i += 1
    return end_status(data, code, pos)


@kernel(inline=True)
def _decode_voxel(
    data, v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, nlow, bias, bias_sum, bias_cnt, held, kinds,
    mix, lpe, lw, models, aux, code, rng, pos, clamp,
):
    """Decode voxel ``i`` into ``v`` and learn from it (``clamp``: as
    :func:`.residmix.learn`; ``kinds``: ``(tex, plane)``, one argument: a call of more
    than 30 is one numba cannot inline); returns ``(impossible value, held, code, rng,
    pos)``."""
    tex, plane = kinds
    pred, ctx, bctx, sctx, mx, q0, q1, q2, q3, q4, q5, pb, lq = _predict_mix(
        v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, bias, held, tex, plane, mix, lpe, lw
    )
    q = _low_class(pred, nlow)
    res, code, rng, pos = get_residual_mix(data, models, ctx, sctx, q, code, rng, pos, aux, mx, clamp)
    val = pred + res
    if res == NO_RESIDUAL or val < 0 or val > hi:
        return True, held, code, rng, pos
    v[np.uint64(i)] = val
    held = _learn(err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
    _learn_local(lw, ctx, val, pb, lq)
    return False, held, code, rng, pos


def _solve(xtx: np.ndarray, xty: np.ndarray) -> np.ndarray:
    """Least-squares weights from the normal equations (16 x 16: a tenth of the time of
    a factorisation of the rows; the weights are rounded to 2^-12 anyway)."""
    w, *_ = np.linalg.lstsq(xtx, xty, rcond=None)
    return np.clip(np.round(w * (1 << CF_BITS)), -CF_LIMIT, CF_LIMIT).astype(np.int64)


_FIT_STEPS = np.array(FIT_OFFSETS, dtype=np.int64)


def _class_weights(xtx, xty, counts, th4) -> list[tuple[np.ndarray, np.ndarray]]:
    """:func:`fit`'s answer from each gradient class's normal equations: the classes'
    weights (a class of fewer than 4 NFIT rows takes those of all) with the thresholds
    ``th4``, and the weights of all with none."""
    every = _solve(xtx.sum(axis=0), xty.sum(axis=0))
    cf = np.zeros(NCLS * NFIT, dtype=np.int64)
    cf1 = cf.copy()
    cf1[:NFIT] = every
    for k in range(NCLS):
        cf[k * NFIT : (k + 1) * NFIT] = _solve(xtx[k], xty[k]) if counts[k] >= 4 * NFIT else every
    return [(cf, th4), (cf1, np.full(NCLS - 1, NO_CLASS, dtype=np.int64))]


@kernel(inline=True)
def _fit_varies(v, steps, z, y, x):
    t = v[z, y, x]
    for j in range(steps.shape[0]):
        if v[z - steps[j, 0], y - steps[j, 1], x - steps[j, 2]] != t:
            return True
    return False


@kernel(inline=True)
def _fit_gradient(v, z, y, x):
    """The row's class measure: |W - NW| + |N - NW| + |N - NE| + |U - UN| + |U - UW|."""
    w, n, u = v[z, y, x - 1], v[z, y - 1, x], v[z - 1, y, x]
    nw, ne, uw, un = v[z, y - 1, x - 1], v[z, y - 1, x + 1], v[z - 1, y, x - 1], v[z - 1, y - 1, x]
    return np.float64(abs(w - nw) + abs(n - nw) + abs(n - ne) + abs(u - un) + abs(u - uw))


@kernel(nrt=False)
def _fit_sums(v, mk, steps, hi, th, g, row, xtx, xty, counts, sums):
    """Over the fit's rows (the voxels of ``v[2:, 2:hi[0], 2:hi[1]]`` not masked and not
    equal to all their neighbours, in C order): each row's gradient into ``g`` (``sums``
    false), or the normal equations of each gradient class split at the thresholds
    ``th`` (``sums`` true; the upper triangle): sums of products of integers, exact in
    float64 below 2^53 in any order, so the weights are those of the whole row matrix
    solved at once, without holding it."""
    k = 0
    nf = steps.shape[0]
    for z in range(2, v.shape[0]):
        for y in range(2, hi[0]):
            for x in range(2, hi[1]):
                if mk[z, y, x] != 0 or not _fit_varies(v, steps, z, y, x):
                    continue
                gk = _fit_gradient(v, z, y, x)
                if not sums:
                    g[k] = gk
                    k += 1
                    continue
                c = 0
                for t in range(th.shape[0]):
                    c += gk > th[t]
                for j in range(nf):
                    row[j] = np.float64(v[z - steps[j, 0], y - steps[j, 1], x - steps[j, 2]])
                t = np.float64(v[z, y, x])
                for i in range(nf):
                    ri = row[i]
                    xty[c, i] += ri * t
                    for j in range(i, nf):
                        xtx[c, i, j] += ri * row[j]
                counts[c] += 1
                k += 1
    return k


@kernel(nrt=False)
def _fit_rows(v, mk, steps, hi, th, z0, z1, rows, counts):
    """The rows of :func:`_fit_sums` in slices ``z0:z1``, each class's in its part of
    ``rows`` (the neighbours, then the voxel), counted in ``counts`` (zeroed here)."""
    nf = steps.shape[0]
    counts[:] = 0
    for z in range(z0, z1):
        for y in range(2, hi[0]):
            for x in range(2, hi[1]):
                if mk[z, y, x] != 0 or not _fit_varies(v, steps, z, y, x):
                    continue
                gk = _fit_gradient(v, z, y, x)
                c = 0
                for t in range(th.shape[0]):
                    c += gk > th[t]
                k = counts[c]
                for j in range(nf):
                    rows[c, k, j] = np.float64(v[z - steps[j, 0], y - steps[j, 1], x - steps[j, 2]])
                rows[c, k, nf] = np.float64(v[z, y, x])
                counts[c] = k + 1


FIT_CHUNK = 1 << 14  # rows a class holds at most between two products in _fit_blocked


def _fit_blocked(v, mk, hi, th, xtx, xty, counts):
    """:func:`_fit_sums` (``sums`` true) as matrix products over blocks of slices: the same
    sums (integers, exact below 2^53 in any order: the caller checks the bound), several
    times faster than the kernel's triangle of products a row."""
    nz, ny, nx = v.shape
    zs = max(1, FIT_CHUNK // ((ny - 3) * (nx - 3)))
    rows = np.empty((NCLS, zs * (ny - 3) * (nx - 3), NFIT + 1))
    got = np.zeros(NCLS, dtype=np.int64)
    for z0 in range(2, nz, zs):
        _fit_rows(v, mk, _FIT_STEPS, hi, th, z0, min(nz, z0 + zs), rows, got)
        for c in range(NCLS):
            if got[c]:
                r = rows[c, : got[c]]
                g = r.T @ r
                xtx[c] += g[:NFIT, :NFIT]
                xty[c] += g[:NFIT, NFIT]
                counts[c] += got[c]


def fit(v: np.ndarray, mask: np.ndarray | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Weights of the fitted predictor for brick ``v`` (values from 0), in 2^-CF_BITS,
    and the gradient classes' thresholds: least squares over the voxels where every
    neighbour exists, that are not masked and whose neighbours do not all equal them.
    Returns ``[(weights, thresholds)]`` for 4 classes (split at the quartiles of the
    gradient) and for 1: ``NCLS * 16`` weights and ``NCLS - 1`` thresholds each.

    Two passes over the brick (the gradients, then each class's normal equations), so
    the fit holds 8 bytes a voxel, not the 136 of the rows (0.3 GB for a 128^3 brick)."""
    nz, ny, nx = v.shape
    cf = np.zeros(NCLS * NFIT, dtype=np.int64)
    th = np.full(NCLS - 1, NO_CLASS, dtype=np.int64)
    if nz < 3 or ny < 3 or nx < 4:
        return [(cf, th), (cf, th)]
    v = np.ascontiguousarray(v, dtype=np.int64)
    mk = np.zeros(v.shape, np.uint8) if mask is None else np.ascontiguousarray(mask, np.uint8)
    hi = np.array([ny - 1, nx - 1], dtype=np.int64)
    g = np.empty((nz - 2) * (ny - 3) * (nx - 3), dtype=np.float64)
    row = np.empty(NFIT)
    xtx, xty = np.zeros((NCLS, NFIT, NFIT)), np.zeros((NCLS, NFIT))
    counts = np.zeros(NCLS, dtype=np.int64)
    n = _fit_sums(v, mk, _FIT_STEPS, hi, np.zeros(0), g, row, xtx, xty, counts, False)
    if n < 4 * NFIT:
        return [(cf, th), (cf, th)]
    th4 = np.minimum(np.quantile(g[:n], np.arange(1, NCLS) / NCLS), NO_CLASS).astype(np.int64)
    top = max(int(v.max()), -int(v.min()))
    small = (ny - 3) * (nx - 3) <= 4 * FIT_CHUNK  # (a slice's rows: the blocks' memory)
    if small and n * top * top < 1 << 53:  # every partial sum exact: products sum the same
        _fit_blocked(v, mk, hi, th4.astype(np.float64), xtx, xty, counts)
    else:
        _fit_sums(v, mk, _FIT_STEPS, hi, th4.astype(np.float64), g, row, xtx, xty, counts, True)
        upper = np.triu_indices(NFIT, 1)
        for c in range(NCLS):  # the products were summed above the diagonal only
            xtx[c][upper[::-1]] = xtx[c][upper]
    return _class_weights(xtx, xty, counts, th4)


PLANE_ROWS = 1 << 8  # image rows a block of fit_plane's rows takes


def _plane_keep(a: np.ndarray, mk: np.ndarray, y0: int, y1: int):
    """Which voxels of image rows ``y0:y1`` of ``a`` (``y0 >= PLANE_REACH``) the planar fit
    takes (not masked, not equal to all their neighbours, as :func:`_fit_sums` for 3-D),
    and their class measure."""
    r, nx = PLANE_REACH, a.shape[1]
    t = a[y0:y1, r : nx - r]

    def at(dy, dx):
        return a[y0 - dy : y1 - dy, r - dx : nx - r - dx]

    varies = np.zeros(t.shape, bool)
    for dy, dx in PLANE_OFFSETS:
        varies |= at(dy, dx) != t
    keep = varies & (mk[y0:y1, r : nx - r] == 0)
    w, n, nw = at(0, 1), at(1, 0), at(1, 1)
    g = abs(w - nw) + abs(n - nw) + abs(n - at(1, -1)) + abs(w - at(0, 2)) + abs(n - at(2, 0))
    return keep, g[keep]


def fit_plane(v: np.ndarray, mask: np.ndarray | None = None):
    """:func:`fit` for the planar predictor of brick ``v`` (values from 0) coded as one
    plane (its slices stacked along y): least squares on :data:`PLANE_OFFSETS`, classes
    split at the quartiles of the in-plane gradient. None where the normal equations'
    sums could pass 2^53 (not exact in float64: their order would matter)."""
    a = np.ascontiguousarray(v, dtype=np.int64).reshape(-1, v.shape[-1])
    mk = np.zeros(a.shape, np.uint8) if mask is None else np.asarray(mask, np.uint8).reshape(a.shape)
    cf = np.zeros(NCLS * NFIT, dtype=np.int64)
    th = np.full(NCLS - 1, NO_CLASS, dtype=np.int64)
    (ny, nx), r = a.shape, PLANE_REACH
    if ny <= r or nx <= 2 * r:
        return [(cf, th), (cf, th)]
    blocks = [(y, min(ny, y + PLANE_ROWS)) for y in range(r, ny, PLANE_ROWS)]
    kept = [_plane_keep(a, mk, y0, y1) for y0, y1 in blocks]
    g = np.concatenate([gk for _, gk in kept])
    n = g.size
    top = max(int(a.max()), -int(a.min()))
    if n * top * top >= 1 << 53:
        return None
    if n < 4 * NFIT:
        return [(cf, th), (cf, th)]
    th4 = np.minimum(np.quantile(g, np.arange(1, NCLS) / NCLS), NO_CLASS).astype(np.int64)
    sums = np.zeros((NCLS, NFIT + 1, NFIT + 1))  # (the neighbours', then the voxel's products)
    counts = np.zeros(NCLS, dtype=np.int64)
    for (y0, y1), (keep, gk) in zip(blocks, kept):
        c = (gk[:, None] > th4[None, :]).sum(1)
        rows = np.empty((gk.size, NFIT + 1))
        for j, (dy, dx) in enumerate(PLANE_OFFSETS + ((0, 0),)):
            rows[:, j] = a[y0 - dy : y1 - dy, r - dx : nx - r - dx][keep]
        for k in range(NCLS):
            part = rows[c == k]
            sums[k] += part.T @ part  # (integers below 2^53 summed: exact in any order)
            counts[k] += len(part)
    xtx, xty = sums[:, :NFIT, :NFIT], sums[:, :NFIT, NFIT]
    return _class_weights(xtx, xty, counts, th4)


def _no_mask(n: int) -> np.ndarray:
    return np.zeros(n, dtype=np.uint8)


def encode(
    values: np.ndarray,
    lo: int,
    hi: int,
    classes: int = NCLS,
    mask=None,
    fitted=None,
    low: bool = False,
    tex: bool = False,
    mix: bool = False,
    local: bool = False,
    plane: bool = False,
    lowm: bool = False,
) -> bytes:
    """Code a 3-D integer array with values in ``[lo, hi]`` (a range below 2^32): the
    thresholds (uint32) and weights (int16) of the fitted predictor (``fitted``, or
    :func:`fit` with ``classes`` 4 or 1), then the stream. Voxels where ``mask`` is
    true are not coded (the decoder is told their value). ``low``: with the low-value
    models, ``tex``: with the texture bias, ``mix``: with the mixed estimates of
    :mod:`.residmix`, ``local``: averaged with the local fit of :mod:`.localfit` (the
    decoder must be told of each; ``local`` only where :func:`.localfit.usable`; ``lowm``:
    with ``low``, the low-value mantissa models, see LOW_MANT); ``plane``:
    the slices coded as one plane by the planar predictor (``fitted`` from
    :func:`fit_plane`; not with ``local``)."""
    v = np.ascontiguousarray(values, dtype=np.int64)
    if v.ndim != 3:
        raise OptionError(f"expected a 3-D array, found shape {v.shape}")
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise OptionError(f"expected a value range of at most 2^32, found [{lo}, {hi}]")
    if classes not in (1, NCLS):
        raise OptionError(f"expected 1 or {NCLS} gradient classes, found {classes}")
    if plane and local:
        raise OptionError("the planar predictor does not take the local fit")
    v = v - lo
    if plane:
        v = v.reshape(1, -1, v.shape[2])
    if fitted is None:
        fits = fit_plane(v, mask) if plane else fit(v, mask)
        if fits is None:
            raise OptionError(f"the planar fit takes values whose sums stay below 2^53, found [{lo}, {hi}]")
        fitted = fits[0 if classes == NCLS else 1]
    cf, th = fitted
    flat = v.reshape(-1)
    mk = _no_mask(flat.size) if mask is None else np.ascontiguousarray(mask, np.uint8).reshape(-1)
    shape = np.array(v.shape, dtype=np.int64)
    if local and not localfit.usable(v.shape, hi - lo):
        raise OptionError(
            f"the local fit takes bricks of at least 3x5x5 with values below "
            f"2^{localfit.MAX_BITS}, found shape {v.shape} and range [{lo}, {hi}]"
        )
    lp = localfit.estimates(v, FIT_OFFSETS).reshape(-1) if local else np.zeros(1, np.int64)
    body = encode_with_retry(
        lambda out: _encode_kernel(
            flat, mk, cf, th, shape, np.int64(hi - lo), _nlow(low, lowm), np.int64(tex), plane, np.int64(mix),
            lp, local, out, *_workspace(v.shape),
        ),
        flat.size,
        (2, 20),
        coder="predictive",
    )
    return th.astype("<u4").tobytes() + cf.astype("<i2").tobytes() + body


def _nlow(low: bool, lowm: bool = False) -> np.int64:
    return np.int64((NLOW | (LOW_MANT if lowm else 0)) if low else 0)


def decode(
    data,
    shape: tuple[int, int, int],
    lo: int,
    hi: int,
    mask=None,
    fill: int = 0,
    low: bool = False,
    tex: bool = False,
    mix: bool = False,
    local: bool = False,
    plane: bool = False,
    lowm: bool = False,
):
    """Decode :func:`encode`'s bytes into an int64 array of ``shape``; voxels where
    ``mask`` is true get ``fill``; ``low``, ``tex``, ``mix``, ``local``, ``plane`` and
    ``lowm`` as for :func:`encode`."""
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise FormatError(f"predictive payload: value range [{lo}, {hi}] is out of bounds")
    if plane and local:
        raise FormatError("predictive payload: the local fit is flagged with the planar predictor")
    if local and not localfit.usable(shape, hi - lo):
        raise FormatError(
            f"predictive payload: the local fit is flagged on a brick it does not apply to "
            f"(shape {tuple(shape)}, range [{lo}, {hi}])"
        )
    data = bytes(data)
    if len(data) < HEAD:
        raise FormatError("predictive payload: the fitted predictor's weights are cut short")
    th = np.frombuffer(data, dtype="<u4", count=NCLS - 1).astype(np.int64)
    cf = np.frombuffer(data, dtype="<i2", count=NCLS * NFIT, offset=4 * (NCLS - 1))
    buf = stream_bytes(data[HEAD:], "predictive")
    n = int(np.prod(shape))
    coded = (1, shape[0] * shape[1], shape[2]) if plane else tuple(shape)
    mk = _no_mask(n) if mask is None else np.ascontiguousarray(mask, np.uint8).reshape(-1)
    v = np.empty(n, dtype=np.int64)
    shp = np.array(coded, dtype=np.int64)
    head = (buf, mk, np.int64(fill - lo), cf.astype(np.int64), th, shp, np.int64(hi - lo), _nlow(low, lowm),
            np.int64(tex), plane, np.int64(mix))  # fmt: skip
    ws = _workspace(coded)
    coder = np.zeros(4, np.int64)
    fit = (localfit.steps(FIT_OFFSETS, shape), *localfit.workspace(shape if local else (1, 1, 1)))
    status = 4 if local else _decode_plain(*head, *fit, v, *ws, np.int64(HANDOVER), coder)
    if status == 4:  # the local fit, or the mix's weights near their bound: the general kernel
        status = _decode_kernel(*head, local, *fit, v, *ws, coder[3], coder)
    check_status(status, "predictive")
    return (v + lo if lo else v).reshape(shape)  # (palette ranks start at 0: no pass)
