"""Logistic mixing of four estimates for the predictive stream's residual decisions
(``predict_version=8``, the payload's ``MIX`` flag; :mod:`.predictfit` codes with it).

Version 7 codes each decision of a residual (zero flag, sign, unary bit length, two
mantissa bits) with one adaptive model picked by the activity context. With ``MIX`` a
decision's probability is a logistic mix, in the stretch domain ``ln(p / (1 - p))``, of
four estimates of it:

1. version 7's own model (activity of the errors around the voxel and the predictors'
   spread, or the low-value models);
2. the same activity over a wider neighbourhood (plus the errors of WW, NN, NWW, NNE);
3. the activity of the nine errors of the 3 x 3 neighbourhood in the slice before;
4. the prediction's magnitude, four levels an octave.

Models 2-4 have the 16-bit states of :mod:`.predictfit`, one per decision slot
(:data:`NSLOT` a context). The mixer's weights (16.16 fixed point, one set of four per
decision kind and activity group: :data:`NSETS`) move by the coding error times each
input, as in PAQ's mixers; everything is integer arithmetic (tables for the stretch and
the squash), so encoder and decoder agree on every platform. Where model 1 is already
sure (a probability of at least ``SURE / 65536`` for one value) it codes alone and
nothing else learns: a flat background's decisions cost no more time than in version 7.
The layout is in ``formats/lossless-1.md`` step 8.8.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from .predict import NACT, NLEN, NSPREAD, activity_class, bitlen

RATE_MAX = 8
NCAP = (1 << RATE_MAX) - 1  # use counts saturate here
# Adaptation rate by use count: a running average (1 / (n + 1)) until 2^-RATE_MAX.
# (uint8, like the mix's tables below kept as narrow as their values: a mixed decision
# reads four model states, four weights and five table entries, and the decoder's
# tables and states are more than its core's first-level cache holds; 256 bytes
# here instead of 2 KB, the stretch and squash 8 KB each instead of 16: 6-8 % of the
# residual decoder's time, measured in results/lossless/ldec36.)
RATE = np.array([min(n.bit_length(), RATE_MAX) for n in range(1, NCAP + 2)], dtype=np.uint8)
MODEL_INIT = (1 << 15) << 8  # probability one half, used 0 times

# Decision slots of one context of models 2-4: the zero flag by the prediction's eighths
# (4), the sign by the sign context (12), the unary length bits (24, the last shared),
# the mantissa bits by bit length (capped at 15) and prefix (64).
S_ZERO, S_SIGN, S_LEN, S_MANT = 0, 4, 16, 40
NLENS = 24
NSLOT = S_MANT + 16 * 4
NLEVEL = 124  # prediction levels: 0..7, then four an octave up to 2^32
NWIDE = NACT * NSPREAD  # model 2's contexts
B_WIDE = 0
B_UP = B_WIDE + NWIDE * NSLOT
B_LEVEL = B_UP + NACT * NSLOT
W_BASE = B_LEVEL + NLEVEL * NSLOT
# Weight sets: decision kind (zero flag, sign, length bits 0..11 and more, the two
# mantissa bits: 16) x activity group (6).
NKIND, NGROUP = 16, 6
NSETS = NKIND * NGROUP
NIN = 4
N_AUX = W_BASE + NSETS * NIN
W_ONE = 1 << 16
W_ZERO = 1 << 31  # weights are kept within +-(W_ZERO - 1): one int32 each, beside the states
SURE = 64512  # model 1 alone from this probability on (of either value)
LR_SHIFT = 16  # weight step: input x error >> LR_SHIFT
ST_MAX = 2047  # the mix's stretch is clipped to +-ST_MAX / 256
P_MIN, P_MAX = 16, 65520
NO_MIX = (np.int64(-1), np.int64(0), np.int64(0), np.int64(0))


def _stretch_table() -> np.ndarray:
    """``round(256 ln(q / (1 - q)))`` at the middle of each of 4096 steps of ``q``."""
    q = (np.arange(4096) + 0.5) / 4096
    return np.round(256 * np.log(q / (1 - q))).astype(np.int16)  # (within +-2307)


def _squash_table() -> np.ndarray:
    """``65536 / (1 + e^(-x / 256))`` for ``x`` in ``-ST_MAX..ST_MAX``, within
    ``P_MIN..P_MAX``."""
    x = np.arange(-ST_MAX, ST_MAX + 1, dtype=np.float64)
    p = np.round(65536 / (1 + np.exp(-x / 256)))
    return np.clip(p, P_MIN, P_MAX).astype(np.uint16)


STRETCH = _stretch_table()
SQUASH = _squash_table()


def workspace() -> np.ndarray:
    """Fresh states of models 2-4 (one half, unused), then the weights (model 1 alone).
    int32: the states are below 2^24 and the weights signed, loaded as they are (an
    offset to take off and put back at each was a tenth of a mixed decision's work)."""
    aux = np.full(N_AUX, MODEL_INIT, dtype=np.int32)
    aux[W_BASE:] = W_ONE // 4
    aux[W_BASE::NIN] = W_ONE // 2
    return aux


@kernel(inline=True)
def adapted(p, n, mask):
    """The state of a model (16-bit probability ``p`` of a 0, use count ``n``) moved
    towards the bit coded (``mask``: -1 for a 1, 0 for a 0). ``p`` stays within
    1..65535."""
    r = np.int64(RATE[np.uint64(n)])
    up = p + ((65536 - p) >> r)  # (p + g - ((g + (p >> r)) & mask), as two moves and a
    down = p - (p >> r)  # select: an instruction less, four times a mixed decision)
    return ((down if mask else up) << 8) | (n + np.int64(n < NCAP))


@kernel(inline=True)
def _err(err, k):
    return abs(err[np.uint64(k)])


@kernel(inline=True)
def _row3(err, b, x0, x1):
    return _err(err, b + x0) + _err(err, b) + _err(err, b + x1)


@kernel(inline=True)
def contexts(err, r, ru, y, x, ny, nx, act, ctx, pred):
    """Per voxel: the first slots of models 2, 3 and 4 and the weights' activity group
    (``mx``, passed to every decision of the voxel). ``err`` is the ring of final errors
    (``r`` the voxel's slot, ``ru`` that of U; the slice before is all decoded, and
    zero before the first slice), ``act`` and ``ctx`` version 7's activity and context,
    ``pred`` the prediction."""
    # model 2: version 7's activity plus the errors two steps back in the slice
    wide = np.int64(0)
    if x >= 2:
        wide += _err(err, r - 2)
    if y >= 2:
        wide += _err(err, r - 2 * nx)
        if x >= 2:
            wide += _err(err, r - 2 * nx - 2)
        if x + 1 < nx:
            wide += _err(err, r - 2 * nx + 1)
    c2 = activity_class(act + (wide >> 1)) * NSPREAD + ctx % NSPREAD
    # model 3: the 3 x 3 errors around U (edges clamped)
    y0 = max(y - 1, 0) - y
    y1 = min(y + 1, ny - 1) - y
    x0 = max(x - 1, 0) - x
    x1 = min(x + 1, nx - 1) - x
    up = _row3(err, ru + y0 * nx, x0, x1) + _row3(err, ru, x0, x1) + _row3(err, ru + y1 * nx, x0, x1)
    c3 = activity_class(up >> 1)
    # model 4: the prediction's level
    nb = bitlen(pred)
    lv = pred if pred < 8 else 8 + 4 * (nb - 4) + ((pred >> (nb - 3)) & 3)
    return (
        B_WIDE + c2 * NSLOT,
        B_UP + c3 * NSLOT,
        B_LEVEL + min(lv, NLEVEL - 1) * NSLOT,
        min(ctx * NGROUP // (NACT * NSPREAD), NGROUP - 1),
    )


@kernel(inline=True)
def mixing(mx, p1):
    """Whether a decision whose model 1 says ``p1`` is mixed."""
    return mx[0] >= 0 and p1 > 65536 - SURE and p1 < SURE


@kernel(inline=True)
def _st(st):
    """Stretch of a model state's probability."""
    return np.int64(STRETCH[np.uint64(st >> 12)])


@kernel(inline=True)
def _w(aux, k):
    return np.int64(aux[np.uint64(k)])


@kernel(inline=True)
def _step(aux, k, w, s, e, clamp):
    """Weight ``k`` (now ``w``) moved by input ``s`` times error ``e``, kept within
    +-(W_ZERO - 1) where ``clamp`` (a constant of the kernel): a caller that knows
    the weights are far enough inside (:func:`room`) leaves the bound out."""
    w += (s * e) >> LR_SHIFT
    if clamp:
        w = min(max(w, 1 - W_ZERO), W_ZERO - 1)
    aux[np.uint64(k)] = w


@kernel(inline=True)
def mix(p1, aux, mx, slot, kind):
    """The mixed probability of a 0 and what :func:`learn` needs: ``(p, s1, s2, s3, s4,
    w index, the four weights, models 2-4's states)`` (handed over rather than loaded
    again: the decoder is bound by its instructions a decision)."""
    s1 = np.int64(STRETCH[np.uint64(p1 >> 4)])
    t2 = np.int64(aux[np.uint64(mx[0] + slot)])
    t3 = np.int64(aux[np.uint64(mx[1] + slot)])
    t4 = np.int64(aux[np.uint64(mx[2] + slot)])
    s2 = _st(t2)
    s3 = _st(t3)
    s4 = _st(t4)
    wb = W_BASE + (kind * NGROUP + mx[3]) * NIN
    w1 = _w(aux, wb)
    w2 = _w(aux, wb + 1)
    w3 = _w(aux, wb + 2)
    w4 = _w(aux, wb + 3)
    dot = w1 * s1 + w2 * s2 + w3 * s3 + w4 * s4
    t = min(max(dot >> 16, -ST_MAX), ST_MAX)
    p = np.int64(SQUASH[np.uint64(t + ST_MAX)])
    return p, (s1, s2, s3, s4, wb, w1, w2, w3, w4, t2, t3, t4)


@kernel(inline=True)
def _learn_model(aux, k, st, mask):
    aux[np.uint64(k)] = adapted(st >> 8, st & 255, mask)


@kernel(inline=True)
def learn(aux, mx, slot, p, held, mask, clamp):
    """After the bit (``mask`` -1 for a 1, 0 for a 0) coded with :func:`mix`'s ``p`` and
    ``held``: the weights step along the error (``clamp``: as :func:`_step`), models
    2-4 adapt."""
    s1, s2, s3, s4, wb, w1, w2, w3, w4, t2, t3, t4 = held
    e = ((mask + 1) << 16) - p
    _step(aux, wb, w1, s1, e, clamp)
    _step(aux, wb + 1, w2, s2, e, clamp)
    _step(aux, wb + 2, w3, s3, e, clamp)
    _step(aux, wb + 3, w4, s4, e, clamp)
    _learn_model(aux, mx[0] + slot, t2, mask)
    _learn_model(aux, mx[1] + slot, t3, mask)
    _learn_model(aux, mx[2] + slot, t4, mask)


# The bound of the weights is two selects on each of four weights a mixed decision, on
# the chain from one voxel's decisions to the next's: 6-10 % of the mixed decoder's time
# (measured). It can only act on a weight within DELTA_MAX * STEPS_MAX * n of it after n
# voxels: a step moves a weight by at most DELTA_MAX (the largest stretch times the
# largest error, 65536 - P_MIN, over 2^16, rounded up), a voxel steps one set of weights
# at most STEPS_MAX times (its decisions: zero flag, sign, NLEN - 1 length bits, two
# mantissa bits).
DELTA_MAX = (int(np.abs(STRETCH).max()) * (65536 - P_MIN) >> LR_SHIFT) + 1
STEPS_MAX = NLEN + 3


@kernel(inline=True)
def room(aux):
    """How many voxels the weights can be stepped without their bound (it cannot act
    within them): 0 or more."""
    m = np.int64(0)
    for k in range(W_BASE, N_AUX):
        m = max(m, abs(np.int64(aux[np.uint64(k)])))
    return max(W_ZERO - 1 - m, 0) // (DELTA_MAX * STEPS_MAX)
