"""Version 8 of the predictive stream (``MIX``: the residual's decisions coded by a
logistic mix of four estimates, :mod:`volpack.volume_codec.residmix`): round trips on
edge cases and real scans, what it saves, version 7 streams unchanged, corrupt flags."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import benchmark_volume, flip_bits, slow_case
from test_predictfit import brain, noisy, roundtrip_stream, tissue

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import predictfit, residmix
from volpack.volume_codec.lossless import (
    FLAG_FIT,
    FLAG_LOW,
    FLAG_MIX,
    FLAG_MORE,
    FLAG_PALETTE,
    FLAG_TEX,
    MIX_MIN_SAVING,
    MODE_PREDICT,
    LosslessCodec,
    describe,
)


def roundtrip_mix(v, lo, hi, mask=None, **opts):
    return roundtrip_stream(v, lo, hi, mask=mask, mix=True, **opts)


@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 9), (1, 7, 1), (5, 1, 1), (2, 2, 2), (3, 4, 5), (9, 17, 13)]
)
def test_mix_roundtrips_every_shape(shape):
    v = noisy(shape, seed=3)
    roundtrip_mix(v, int(v.min()), int(v.max()), low=True, tex=True)


def test_mix_roundtrips_wide_and_extreme_ranges():
    rng = np.random.default_rng(5)
    v = noisy((10, 12, 14), noise=40) * 250  # 16-bit-like steps: long lengths
    roundtrip_mix(v, 0, int(v.max()), tex=True)
    # a range of 2^32 - 1: predictions reach the last levels of model 4, residuals 32 bits
    w = rng.integers(0, 1 << 32, size=(6, 7, 9), dtype=np.int64)
    w[0, 0, 0], w[-1, -1, -1] = 0, (1 << 32) - 1
    roundtrip_mix(w, 0, (1 << 32) - 1)
    roundtrip_mix(np.full((4, 5, 6), 7, np.int64), 7, 7)  # one value: nothing mixed
    c = np.indices((8, 9, 10)).sum(axis=0) % 2 * 255  # checkerboard: every decision sure
    roundtrip_mix(c.astype(np.int64), 0, 255, low=True)


def test_mix_with_mask_low_and_texture_roundtrips_and_pays():
    v = tissue()
    lo, hi = int(v.min()), int(v.max())
    for low in (False, True):
        plain = predictfit.encode(v, lo, hi, low=low, tex=True)
        mixed = roundtrip_mix(v, lo, hi, low=low, tex=True)
        assert len(mixed) < 0.99 * len(plain)  # (measured: 0.986 of the bytes)
    b = brain()
    m = b == 0
    roundtrip_mix(b, 0, 255, mask=m, low=True, tex=True)
    roundtrip_mix(np.zeros_like(b), 0, 255, mask=np.ones(b.shape, bool))  # nothing coded


def test_version_8_keeps_mix_where_it_pays_and_version_7_is_unchanged():
    a = tissue().astype(np.uint8)
    v8 = LosslessCodec().encode(a)
    v7 = LosslessCodec(predict_version=7).encode(a)
    assert v8[0] == MODE_PREDICT and v8[1] & FLAG_FIT and v8[1] & FLAG_MORE
    assert v8[2] == FLAG_MIX >> 8
    assert not v7[1] & FLAG_MORE and v7[1] & FLAG_TEX
    assert len(v8) < (1 - MIX_MIN_SAVING) * len(v7)
    assert describe(v8) == describe(v7) + "+mix"
    np.testing.assert_array_equal(LosslessCodec().decode(v8, a.shape, a.dtype), a)
    np.testing.assert_array_equal(LosslessCodec().decode(v7, a.shape, a.dtype), a)
    # a brick where the mix does not save MIX_MIN_SAVING is written as version 7
    flat = np.zeros((12, 12, 12), np.uint8)
    flat[6:] = 9
    flat[3, 4, 5] = 1
    assert LosslessCodec().encode(flat) == LosslessCodec(predict_version=7).encode(flat)


def test_mix_same_bytes_for_any_worker_count():
    a = np.concatenate([tissue(), tissue()[::-1]]).astype(np.uint8)
    one = api.compress_array(a, brick=32, workers=1)
    assert api.compress_array(a, brick=32, workers=2) == one
    np.testing.assert_array_equal(api.decompress_array(one, workers=2), a)
    with Reader(one) as r:
        assert all(describe(p).endswith("+mix") for _, _, p in r)


@pytest.mark.slow  # the general predictfit decoder: a kernel only the local fit shares (kernel_use36.md)
def test_corrupt_mix_sections_raise_format_error():
    codec = LosslessCodec()
    a = tissue().astype(np.uint8)
    good = codec.encode(a)
    flags = good[1]
    assert flags & FLAG_MORE and flags & FLAG_LOW
    bad = [
        good[:2],  # the second flags byte missing
        bytes([MODE_PREDICT, flags, 0]) + good[3:],  # a second byte without MIX
        bytes([MODE_PREDICT, flags, 3]) + good[3:],  # unknown flag 512
        bytes([MODE_PREDICT, flags, 0x81]) + good[3:],
        bytes([MODE_PREDICT, FLAG_MORE | FLAG_PALETTE, 1]) + good[3:],  # labels, not MIX
        good[: len(good) // 2],  # truncated
        good + b"\x00",  # trailing byte
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    flip_bits(codec, bytearray(good), a, np.random.default_rng(9), 30)


def test_stretch_and_squash_tables():
    """The mix's integer tables against their definitions: monotone, odd, and squash
    undoing stretch over the probabilities the mix sees, within the 12-bit index's step
    (16) plus the stretch's rounding (half a 1/256 step, at most 32 of 65536)."""
    st, sq = residmix.STRETCH, residmix.SQUASH
    assert (np.diff(st) >= 0).all() and (st == -st[::-1]).all()
    assert (np.diff(sq) >= 0).all() and sq[0] >= residmix.P_MIN and sq[-1] <= residmix.P_MAX
    p = np.arange(65536 - residmix.SURE + 1, residmix.SURE)
    back = sq[np.clip(st[p >> 4], -residmix.ST_MAX, residmix.ST_MAX) + residmix.ST_MAX]
    assert np.abs(back - p).max() <= 16 + 32


REAL = ["brainsmall", "mri_dipy_s0", "mri_nibabel_t1", "mri_epi_nibabel"]


@pytest.mark.slow
@pytest.mark.parametrize("name", REAL)
def test_real_scans_roundtrip_and_version_8_is_no_longer(name):
    """The four short scans of issue 20 (data cache; skipped without it): version 8
    round-trips and is shorter than version 7 on every one."""
    a = benchmark_volume(name)
    v8 = api.compress_array(a)
    np.testing.assert_array_equal(api.decompress_array(v8, workers=2), a)
    assert len(v8) < len(api.compress_array(a, predict_version=7))


# The decoder leaves the weights' bound out while residmix.room says it cannot act, and
# hands the rest of the brick to the general kernel (bound in) where it could.


@pytest.mark.slow  # the general predictfit decoder: a kernel only the local fit shares (kernel_use36.md)
@pytest.mark.parametrize("stop", [0, 1, 9, 40, 14 * 16 - 1])
def test_handover_to_the_general_kernel_decodes_the_same(monkeypatch, stop):
    """Handing over at any row (the first, the second, within a slice, the last) gives
    the stream's voxels: the coder's state, the row and the learnt state carry over."""
    v = brain((14, 16, 18), seed=4)
    mask = v == 0
    data = predictfit.encode(v, 0, int(v.max()), mask=mask, low=True, tex=True, mix=True)
    monkeypatch.setattr(predictfit, "HANDOVER", stop)
    back = predictfit.decode(data, v.shape, 0, int(v.max()), mask, 0, low=True, tex=True, mix=True)
    np.testing.assert_array_equal(back, v)


def test_weights_bound_cannot_act_within_room():
    """One step moves a weight by at most DELTA_MAX, a voxel steps a set at most STEPS_MAX
    times (every decision of its longest residual), and room is the naive count."""
    s = np.abs(residmix.STRETCH.astype(np.int64)).max()
    e = 65536 - residmix.P_MIN
    worst = max(abs((a * b) >> residmix.LR_SHIFT) for a in (-s, s) for b in (-e, e))
    assert residmix.DELTA_MAX >= worst
    assert residmix.STEPS_MAX >= 1 + 1 + (predictfit.NLEN - 1) + 2
    aux = residmix.workspace()
    per = residmix.DELTA_MAX * residmix.STEPS_MAX
    w = np.abs(aux[residmix.W_BASE :].astype(np.int64)).max()
    assert residmix.room(aux) == (residmix.W_ZERO - 1 - w) // per
    aux[-3] = -(residmix.W_ZERO - 1) + 5 * per
    assert residmix.room(aux) == 5
    aux[-3] = residmix.W_ZERO - 1
    assert residmix.room(aux) == 0


@pytest.mark.parametrize("margin", [slow_case(0), 3])
def test_weights_at_their_bound_decode_the_same(monkeypatch, margin):
    """Weights started at (or ``margin`` rows of steps from) their bound, where the encoder
    clamps them: the decoder finds no room (at once, or after a few rows) and the general
    kernel, bound in, decodes the stream."""
    fresh = residmix.workspace

    def near_bound():
        aux = fresh()
        top = residmix.W_ZERO - 1 - margin * 18 * residmix.DELTA_MAX * residmix.STEPS_MAX
        aux[residmix.W_BASE :: 2] = top
        aux[residmix.W_BASE + 1 :: 2] = -top
        return aux

    monkeypatch.setattr(residmix, "workspace", near_bound)
    v = noisy((8, 12, 18), seed=6, noise=12)
    roundtrip_mix(v, int(v.min()), int(v.max()), low=True, tex=True)


def test_tables_are_narrow_and_hold_their_definitions():
    """The mixed decision reads five table entries: the rates, stretch and squash are
    kept as narrow as their values (uint8, int16, uint16: ldec36's 6-8 % of the residual
    decoder), the values those of the wide definitions; the bias counts (below 64) uint8."""
    assert residmix.RATE.dtype == np.uint8 and residmix.STRETCH.dtype == np.int16
    assert residmix.SQUASH.dtype == np.uint16
    rate = [min(n.bit_length(), residmix.RATE_MAX) for n in range(1, residmix.NCAP + 2)]
    assert residmix.RATE.tolist() == rate
    q = (np.arange(4096) + 0.5) / 4096
    assert (residmix.STRETCH == np.round(256 * np.log(q / (1 - q)))).all()
    x = np.arange(-residmix.ST_MAX, residmix.ST_MAX + 1)
    sq = np.clip(np.round(65536 / (1 + np.exp(-x / 256))), residmix.P_MIN, residmix.P_MAX)
    assert (residmix.SQUASH == sq).all()
    assert predictfit._workspace((2, 3, 4))[3].dtype == np.uint8


def test_adapted_is_the_masked_move():
    """``adapted`` (two moves and a select) gives the state of the masked form it
    replaced, ``p + g - ((g + (p >> r)) & mask)``, for every use count and both bits."""
    rng = np.random.default_rng(36)
    ps = np.concatenate([np.arange(1, 33), np.arange(65504, 65536), rng.integers(1, 65536, 64)])
    for n in range(residmix.NCAP + 1):
        r = int(residmix.RATE[n])
        for p in ps.tolist():
            for mask in (0, -1):
                g = (65536 - p) >> r
                want = ((p + g - ((g + (p >> r)) & mask)) << 8) | (n + (n < residmix.NCAP))
                assert residmix.adapted.py_func(p, n, mask) == want
