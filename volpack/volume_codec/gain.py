"""Gain combs: integers that are a count times a gain plus a little noise, coded as two.

A photon-counting detector's frames after the dark is taken off (an x-ray free-electron
laser's, session 38's EXAFEL-like stack) read ``v = g k + e``: ``k`` photons (Poisson, a
picture with spots and rings) times a gain of ``g`` ADU, plus read noise ``e`` of a few
ADU, white from pixel to pixel. The values' histogram is a comb of period ``g``. Coded
voxel by voxel, a predictor sees ``k`` only through the noise, and the noise's residual
through ``k``'s steps (session 38: 1.175x the stack's Shannon bound, where JPEG-XL e9 is
1.179x). Here a brick whose histogram is such a comb is split into ``k = (v + s) // g``
and ``r = (v + s) - g k`` in ``[0, g)`` (the shift ``s`` puts the comb's peak at
``g // 2``), both of the brick's dtype, each coded by the lossless codec as any brick
(mode 8 of ``formats/lossless-1.md``); ``v = g k + r - s``.
"""

from __future__ import annotations

import numpy as np

from ..errors import FormatError
from .palette import read_uleb, uleb

GAINS = (8, 256)  # the periods looked at, first and last (shorter: the teeth of noise overlap)
MAX_SPAN = 1 << 20  # bricks whose values span more are not looked at (a histogram of the span)
# A comb of period g: the values at least g / 2 from the most frequent one (the k = 0
# peak's, or a background's: one peak is concentrated under every period) are at least
# MIN_STEPPED of the voxels, and folded by g they take 2^H <= WIDTH * g residues (H their
# entropy) around one peak, in two teeth (k levels) or more. A histogram of a few broad
# peaks (a CT's air and tissues) folds to a spread. A period near the comb's (29 for 30)
# may pass too, and a multiple of it: of the passing periods below twice the first, the
# tightest fold is taken.
WIDTH = 0.5
MIN_STEPPED = 0.02
MIN_TOOTH = 0.002  # and two teeth at least besides the peak's own hold this share each
GAP = 0.03  # and at most this share of them lie in the quarter of residues between teeth
# The teeth are noise about their centres: at most this share on one residue, and every
# residue within g / 4 of the centre taken (labels, exact values, are for the palette:
# session 38 found combs in 21 bricks of eight label maps without these rules)
PEAK = 0.5
VALUES = 2  # and the values away from the peak are at least this many times g in number
# Each of those teeth is centred on the fold's peak (its mean residue within CENTRE g of
# it) and narrow (a spread of at most SPREAD g): detector frames' teeth are within 0.01 g
# and 0.1 g; session 38's held-out MR angiography (vessels of a few levels over a Rician
# background) passed the rules above in two bricks with teeth 0.08-0.21 g off and spreads
# up to 0.34 g (tried, not kept: 1.86x the encode CPU), and takes no comb with this rule.
CENTRE = 1 / 16
SPREAD = 1 / 6


def _entropy(counts: np.ndarray) -> float:
    p = counts[counts > 0] / counts.sum()
    return float(-(p * np.log2(p)).sum())


def _centred(r: np.ndarray, t: np.ndarray, w: np.ndarray, teeth: np.ndarray, g: int) -> bool:
    """Every tooth of ``teeth`` (indices into ``t``) has its residues' weighted mean within
    :data:`CENTRE` g of ``g // 2`` and their spread at most :data:`SPREAD` g."""
    for i in teeth:
        m = t == i
        mean = float((r[m] * w[m]).sum() / w[m].sum())
        sd = float(np.sqrt(((r[m] - mean) ** 2 * w[m]).sum() / w[m].sum()))
        if abs(mean - g // 2) > CENTRE * g or sd > SPREAD * g:
            return False
    return True


def find(brick: np.ndarray) -> tuple[int, int] | None:
    """``(g, s)``: the period ``g`` in :data:`GAINS` under which ``brick``'s values are
    a comb (of those from the first that passes to below twice it, the one whose fold has
    the least entropy) and the shift that centres its peak; None where there is none."""
    if brick.dtype.kind not in "iu" or brick.dtype.itemsize > 4 or brick.size < 64:
        return None
    lo, hi = int(brick.min()), int(brick.max())
    if hi - lo > MAX_SPAN or hi - lo < 2 * GAINS[0]:
        return None
    hist = np.bincount((brick.reshape(-1).astype(np.int64) - lo), minlength=hi - lo + 1)
    top = int(np.argmax(hist))
    vals = np.nonzero(hist)[0]
    w = hist[vals].astype(np.float64)
    far = np.abs(vals - top)
    found = []  # (entropy of the fold, g, shift) of every period that passes
    for g in range(GAINS[0], min(GAINS[1], (hi - lo) // 2) + 1):
        if found and g >= 2 * found[0][1]:
            break  # a multiple of a comb's period folds it as well: the first octave only
        away = far >= g // 2 + 1
        if w[away].sum() < MIN_STEPPED * brick.size:
            break  # (fewer still at longer periods)
        if np.count_nonzero(away) < VALUES * g:
            continue  # a few values (labels), not teeth of noise
        fold = np.bincount((vals[away] + lo) % g, weights=w[away], minlength=g)
        h = _entropy(fold)
        if 2.0**h > WIDTH * g or fold.max() > PEAK * fold.sum():
            continue
        shift = (g // 2 - int(np.argmax(fold))) % g
        r = (np.arange(g) + shift) % g  # each residue's place once centred
        if fold[np.abs(r - g // 2) > 3 * g // 8].sum() > GAP * fold.sum():
            continue  # no empty gaps between the teeth: a band, not a comb
        if not fold[np.abs(r - g // 2) <= g // 4].all():
            continue  # a tooth of scattered values (labels), not noise about a centre
        v = vals[away] + lo + shift
        k = v // g
        teeth = np.bincount(k - k.min(), weights=w[away])
        own = (top + lo + shift) // g - k.min()  # the peak's own tooth
        if 0 <= own < len(teeth):
            teeth[own] = 0
        big = np.nonzero(teeth >= MIN_TOOTH * brick.size)[0]
        if len(big) < 2:
            continue  # one broad peak narrower than g / 2, not a comb
        if not _centred(v - g * k, k - k.min(), w[away], big, g):
            continue  # teeth off the comb's centre or wide: structures, not noise
        found.append((h, g, shift))
    if not found:
        return None
    _, g, shift = min(found)  # the period the teeth fold onto most tightly
    return g, shift


def split(brick: np.ndarray, g: int, s: int) -> tuple[np.ndarray, np.ndarray]:
    """``(k, r)`` of ``brick``'s dtype: ``brick = g k + r - s``, ``0 <= r < g``."""
    v = brick.astype(np.int64) + s
    k = np.floor_divide(v, g)
    return k.astype(brick.dtype), (v - g * k).astype(brick.dtype)


def join(k: np.ndarray, r: np.ndarray, g: int, s: int, dtype: np.dtype) -> np.ndarray:
    """The brick back from ``k`` and ``r``; a value outside ``dtype`` or an ``r`` outside
    ``[0, g)`` is a FormatError."""
    rr = r.astype(np.int64)
    if rr.size and (rr.min() < 0 or rr.max() >= g):
        raise FormatError(f"gain-comb payload: a residue outside [0, {g})")
    v = g * k.astype(np.int64) + rr - s
    info = np.iinfo(dtype)
    if v.size and (v.min() < info.min or v.max() > info.max):
        raise FormatError(f"gain-comb payload: a value outside {np.dtype(dtype)}")
    return v.astype(dtype)


def pack(g: int, s: int, k_payload: bytes) -> bytes:
    """The header of mode 8 after its mode byte: g, s, the length of k's payload, k's payload."""
    return uleb(g) + uleb(s) + uleb(len(k_payload)) + k_payload


def unpack(data: memoryview) -> tuple[int, int, int, int]:
    """``(g, s, start of k's payload, its length)``."""
    g, pos = read_uleb(data, 0)
    s, pos = read_uleb(data, pos)
    n, pos = read_uleb(data, pos)
    if not 2 <= g <= 1 << 16 or s >= g:
        raise FormatError(
            f"gain-comb payload: expected 2 <= g <= 65536 and s < g, found g {g}, s {s}"
        )
    if pos + n > len(data):
        raise FormatError("gain-comb payload: k's payload runs past the payload")
    return g, s, pos, n
