"""Version 2 of the predictive stream (fitted predictor, eighths, 16-bit models) and the
background mask: round trips, mask patterns, what it saves, headers of version 1,
golden streams and corrupt sections."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import flip_bits, traced_peak
from naive import predict_fit_weights

from volpack import api
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader
from volpack.volume_codec import bgmask, palette, predictfit
from volpack.volume_codec.lossless import (
    FLAG_FIT,
    FLAG_FLOAT,
    FLAG_LOW,
    FLAG_MASK,
    FLAG_PALETTE,
    FLAG_TEX,
    MODE_PREDICT,
    VERSIONS,
    LosslessCodec,
    _encode_fit,
)

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"


def noisy(shape, seed=0, noise=3.0):
    """A smooth field with noise, as an MRI's tissue."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    f = 90 + 40 * np.sin(x / 5.0) * np.cos(y / 7.0) + 2 * z + rng.normal(0, noise, shape)
    return np.clip(np.rint(f), 1, 255).astype(np.int64)


def brain(shape=(24, 40, 40), seed=1):
    """Noisy tissue inside an ellipsoid, zero around it (a skull-stripped scan)."""
    z, y, x = np.indices(shape)
    c = np.array(shape) / 2
    inside = ((z - c[0]) / c[0]) ** 2 + ((y - c[1]) / c[1]) ** 2 + ((x - c[2]) / c[2]) ** 2 < 0.8
    return np.where(inside, noisy(shape, seed), 0)


def roundtrip_stream(v, lo, hi, classes=4, mask=None, **opts):
    """Code and decode ``v`` with ``opts`` (``low``, ``tex``, ``mix``, ``local``)."""
    data = predictfit.encode(v, lo, hi, classes=classes, mask=mask, **opts)
    fill = int(v[mask].flat[0]) if mask is not None and mask.any() else lo
    back = predictfit.decode(data, v.shape, lo, hi, mask, fill, **opts)
    np.testing.assert_array_equal(back, v)
    return data


@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 9), (1, 7, 1), (5, 1, 1), (3, 4, 5), (3, 3, 4), (9, 17, 13)]
)
@pytest.mark.parametrize("classes", [1, 4])
def test_roundtrip_every_shape(shape, classes):
    v = noisy(shape)
    roundtrip_stream(v, int(v.min()), int(v.max()), classes)


def test_extreme_ranges():
    rng = np.random.default_rng(3)
    lo, hi = -(1 << 31), (1 << 31) - 1  # int32: predictions in eighths reach 2^35
    v = rng.integers(lo, hi, (6, 7, 9), endpoint=True)
    v[2:4] = lo
    v[4:] = hi
    roundtrip_stream(v, lo, hi)
    roundtrip_stream(np.full((4, 5, 6), 7), 7, 7)
    with pytest.raises(OptionError):
        predictfit.encode(v, lo, lo + (1 << 32))
    with pytest.raises(OptionError):
        predictfit.encode(v, lo, hi, classes=5)


def _masks(shape):
    """The stability cases: empty, full, one voxel, checkerboard, every brick face
    (bricks of 8), a whole brick."""
    z, y, x = np.indices(shape)
    faces = (z % 8 == 0) | (z % 8 == 7) | (y % 8 == 0) | (y % 8 == 7) | (x % 8 == 0) | (x % 8 == 7)
    one = np.zeros(shape, bool)
    one[3, 4, 5] = True
    block = np.zeros(shape, bool)
    block[:8, :8, :8] = True
    return {
        "empty": np.zeros(shape, bool),
        "full": np.ones(shape, bool),
        "one": one,
        "checker": (z + y + x) % 2 == 0,
        "faces": faces,
        "block": block,
    }


@pytest.mark.parametrize("name", list(_masks((8, 8, 8))))
def test_mask_patterns_roundtrip_in_the_stream(name):
    shape = (16, 16, 16)
    mask = _masks(shape)[name]
    v = np.where(mask, 0, noisy(shape))
    roundtrip_stream(v, 0, int(v.max()) or 1, mask=mask)
    section = bgmask.encode(0, mask)
    fill, back, used = bgmask.decode(memoryview(section), shape, 5)
    assert fill == 0 and used == len(section)
    np.testing.assert_array_equal(back, mask)


@pytest.mark.parametrize("name", list(_masks((8, 8, 8))))
def test_mask_patterns_roundtrip_through_the_codec(name):
    shape = (16, 24, 20)
    mask = _masks(shape)[name]
    a = np.where(mask, 0, noisy(shape)).astype(np.uint8)
    blob = api.compress_array(a, brick=8)
    np.testing.assert_array_equal(api.decompress_array(blob), a)
    blob = api.compress_array(a, brick=16, tools="predict")
    np.testing.assert_array_equal(api.decompress_array(blob), a)


def test_masked_voxels_leave_no_trace():
    """Whatever the masked voxels hold, the other voxels' code is the same: the
    predictor sees the fill value there and learns nothing from them."""
    v = brain()
    mask = v == 0
    a = predictfit.encode(v, 0, 255, mask=mask)
    w = v.copy()
    w[mask] = 0
    assert predictfit.encode(w, 0, 255, mask=mask) == a


def test_mask_and_fit_pay_on_a_skull_stripped_volume():
    a = brain((32, 48, 48)).astype(np.uint8)
    v1 = api.compress_array(a, brick=64, predict_version=1)
    v2 = api.compress_array(a, brick=64)
    with Reader(v2) as r:
        (tool,) = r.summary["tools"]
    assert tool.startswith("predict2") and "+mask" in tool
    assert len(v2) < 0.97 * len(v1)
    v = a.astype(np.int64)
    plain = predictfit.encode(v, 0, 255)
    masked = predictfit.encode(v, 0, 255, mask=v == 0) + bgmask.encode(0, v == 0)
    assert len(masked) < len(plain)


def test_fitted_predictor_pays_on_noise():
    v = noisy((32, 32, 32), noise=4)
    from volpack.volume_codec import predict

    # white noise on a smooth field: measured -1.8 % (real MRIs: -2 to -4 %, README)
    assert len(predictfit.encode(v, 0, 255)) < 0.99 * len(predict.encode(v, 0, 255))


def test_version_one_headers():
    """A header without predict_version reads as version 1 and version 1 writes none,
    so the files before version 2 are reproduced byte for byte."""
    old = LosslessCodec(predict_version=1)
    assert "predict_version" not in old.get_config()
    assert LosslessCodec.from_config(old.get_config()) == old
    assert LosslessCodec().get_config()["predict_version"] == 8
    assert LosslessCodec.from_config(LosslessCodec().get_config()) == LosslessCodec()
    past = max(VERSIONS) + 1  # a version no encoder of this tree writes
    with pytest.raises(OptionError):
        LosslessCodec(predict_version=past)
    with pytest.raises(FormatError):
        LosslessCodec.from_config({**LosslessCodec().get_config(), "predict_version": past})


def test_golden_streams_use_the_new_sections():
    seen = set()
    for stem in ("lossless-v2-u8-mask", "lossless-v2-i16-palette", "lossless-v2-predict-u8"):
        with Reader((GOLDEN / f"{stem}.vpk").read_bytes()) as r:
            for e in r.entries:
                p = r.read(e.t, e.node)
                if p[0] == MODE_PREDICT:
                    seen.add(p[1])
    assert FLAG_FIT in seen
    assert FLAG_FIT | FLAG_PALETTE in seen
    assert FLAG_FIT | FLAG_PALETTE | FLAG_MASK in seen


def floored(shape=(16, 24, 24), seed=1):
    """:func:`brain` over a noise floor of 0..5 in which 1 is rare (as the floor of a
    magnitude image, whose histogram no residual model fits)."""
    v = brain(shape, seed)
    rng = np.random.default_rng(seed)
    floor = np.array([0, 0, 2, 2, 3, 3, 3, 3, 4, 4, 5, 1])[rng.integers(0, 12, shape)]
    return np.where(v == 0, floor, v)


def test_low_value_models_roundtrip_and_pay():
    v = floored()
    for mask in (None, v == 3):
        fill = 3 if mask is not None else 0
        plain = predictfit.encode(v, 0, 255, mask=mask)
        low = predictfit.encode(v, 0, 255, mask=mask, low=True)
        np.testing.assert_array_equal(predictfit.decode(low, v.shape, 0, 255, mask, fill, low=True), v)
        # (measured: 0.84 and 0.88 of the bytes)
        assert len(low) < 0.95 * len(plain)
    payload = LosslessCodec().encode(v.astype(np.uint8))
    assert payload[1] & FLAG_LOW
    assert len(payload) < 0.95 * len(LosslessCodec(predict_version=4).encode(v.astype(np.uint8)))


def test_low_value_models_same_bytes_for_any_worker_count():
    a = floored((20, 24, 40), seed=2).astype(np.uint8)
    one = api.compress_array(a, brick=16, workers=1)
    assert api.compress_array(a, brick=16, workers=2) == one
    np.testing.assert_array_equal(api.decompress_array(one, workers=2), a)


def test_corrupt_low_value_sections_raise_format_error():
    codec = LosslessCodec()
    a = floored().astype(np.uint8)
    good = codec.encode(a)
    assert good[0] == MODE_PREDICT and good[1] & FLAG_LOW
    bad = [
        bytes([MODE_PREDICT, FLAG_LOW]) + good[2:],  # low-value models without version 2
        bytes([MODE_PREDICT, FLAG_LOW | FLAG_PALETTE]) + good[2:],
        good[: len(good) // 2],  # truncated
        good[:-3],
        good + b"\x00",  # trailing byte
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    flip_bits(codec, bytearray(good), a, np.random.default_rng(7), 20)


def tissue():
    """A 32^3 cut of the bundled MRI's tissue (the golden lossless-v7 example's)."""
    from volpack.demo import load_demo_volume

    return np.ascontiguousarray(load_demo_volume().data[30:62, 40:72, 40:72]).astype(np.int64)


@pytest.mark.slow
def test_texture_bias_roundtrips_and_pays():
    v = tissue()
    lo, hi = int(v.min()), int(v.max())
    for low in (False, True):
        plain = predictfit.encode(v, lo, hi, low=low)
        tex = predictfit.encode(v, lo, hi, low=low, tex=True)
        np.testing.assert_array_equal(predictfit.decode(tex, v.shape, lo, hi, low=low, tex=True), v)
        assert len(tex) < len(plain)  # (measured: 0.996 of the bytes)
    b = brain()
    m = b == 0
    tex = predictfit.encode(b, 0, 255, mask=m, tex=True)
    np.testing.assert_array_equal(predictfit.decode(tex, b.shape, 0, 255, m, 0, tex=True), b)
    payload = LosslessCodec().encode(v.astype(np.uint8))
    before = LosslessCodec(predict_version=6).encode(v.astype(np.uint8))
    assert payload[1] & FLAG_TEX and not before[1] & FLAG_TEX
    assert len(payload) < len(before)


@pytest.mark.slow
def test_corrupt_texture_bias_sections_raise_format_error():
    codec = LosslessCodec()
    a = tissue().astype(np.uint8)
    good = codec.encode(a)
    assert good[0] == MODE_PREDICT and good[1] & FLAG_TEX
    bad = [
        bytes([MODE_PREDICT, FLAG_TEX]) + good[2:],  # the texture bias without version 2
        bytes([MODE_PREDICT, FLAG_TEX | FLAG_PALETTE]) + good[2:],
        good[: len(good) // 2],  # truncated
        good + b"\x00",  # trailing byte
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    flip_bits(codec, bytearray(good), a, np.random.default_rng(8), 20)


def version2(a):
    """A version-2 payload of brick ``a`` (the codec may keep version 1 on small bricks)."""
    v = a.astype(np.int64)
    return _encode_fit(v, int(v.min()), int(v.max()))


def test_small_bricks_keep_version_one_when_it_is_shorter():
    a = (noisy((6, 7, 8)) * 16).astype(np.int16)
    payload = LosslessCodec().encode(a)
    assert len(payload) <= len(LosslessCodec(predict_version=1).encode(a))
    assert len(payload) < len(version2(a))


def test_corrupt_sections_raise_format_error():
    codec = LosslessCodec()
    a = brain((16, 24, 24)).astype(np.uint8)
    good = version2(a)
    assert good[0] == MODE_PREDICT and good[1] & FLAG_FIT and good[1] & FLAG_MASK
    head = bytes([MODE_PREDICT, FLAG_FIT]) + palette.uleb(0) + palette.uleb(255)
    weights = bytes(predictfit.HEAD)
    bad = [
        bytes([MODE_PREDICT, FLAG_FIT | FLAG_FLOAT]) + good[2:],  # float flag on integers
        bytes([MODE_PREDICT, FLAG_MASK]) + good[2:],  # a mask without version 2
        head,  # no weights
        head + weights[:-1],  # weights cut short
        head + weights,  # no stream
        bytes([MODE_PREDICT, FLAG_FIT | FLAG_MASK]) + palette.uleb(0) + palette.uleb(255),
        bytes([MODE_PREDICT, FLAG_FIT | FLAG_MASK]) + palette.uleb(0) + palette.uleb(9)
        + palette.uleb(10) + palette.uleb(0),  # masked value above the range
        bytes([MODE_PREDICT, FLAG_FIT | FLAG_MASK]) + palette.uleb(0) + palette.uleb(9)
        + palette.uleb(0) + palette.uleb(500) + b"\x00",  # mask stream past the end
        good[: len(good) // 2],  # truncated
        good + b"\x00",  # trailing byte
    ]  # fmt: skip
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)


def test_bit_flips_raise_or_decode():
    codec = LosslessCodec()
    rng = np.random.default_rng(5)
    for a in (brain((16, 24, 24)).astype(np.uint8), (noisy((6, 7, 8)) * 16).astype(np.int16)):
        good = bytearray(version2(a))
        assert good[1] & FLAG_FIT
        flip_bits(codec, good, a, rng, 40)


def test_weight_table_matches_its_definition():
    """The squared weights come from one table (W2): every entry, and the saturation past
    it, as the reciprocal, the shift and the square of predict.weight work them out."""
    from volpack.volume_codec.predict import RECIP

    def weight2(s):  # predict.weight(s + 1), squared and shifted, in plain Python
        t = s + 1
        sh = max(t.bit_length() - 8, 0)
        w = max(int(RECIP[t >> sh]) >> sh, 1)
        return max((w * w) >> 24, 1)

    ss = list(range(predictfit.W2_SPAN + 64)) + [1 << 20, 5 * (1 << 30)]
    got = [int(predictfit.W2[min(s, predictfit.W2_SPAN - 1)]) for s in ss]
    assert got == [weight2(s) for s in ss]


@pytest.mark.parametrize("masked", [False, True])
def test_fit_matches_the_whole_row_matrix(masked):
    """The fit's two passes (gradients, then each class's normal equations summed row by
    row) against the row matrix stacked whole and solved per class (tests/naive.py): the
    sums are of integers, exact in any order, so the rounded weights are the same."""
    rng = np.random.default_rng(7)
    v = np.cumsum(rng.integers(-3, 4, size=(9, 14, 17)), axis=2) + 40
    v[:, :5, :6] = 2  # a flat corner: voxels whose neighbours all equal them are left out
    mask = rng.random(v.shape) < 0.3 if masked else None
    (cf, th4), (cf1, th1) = predictfit.fit(v, mask)
    want, want_th, want_every = predict_fit_weights(v, predictfit.FIT_OFFSETS, mask)
    np.testing.assert_array_equal(th4, np.minimum(want_th, predictfit.NO_CLASS).astype(np.int64))
    np.testing.assert_array_equal(cf, want)
    np.testing.assert_array_equal(cf1[: predictfit.NFIT], want_every)
    assert (th1 == predictfit.NO_CLASS).all() and not cf1[predictfit.NFIT :].any()


def test_fit_memory_does_not_grow_with_the_rows():
    """A 96x128x128 brick's fit holds a gradient a voxel (8 bytes), not the rows (136
    bytes a voxel: 214 MB here)."""
    rng = np.random.default_rng(3)
    v = np.cumsum(rng.integers(-2, 3, size=(96, 128, 128)), axis=2) + 500
    fits, peak = traced_peak(predictfit.fit, v)
    assert fits[0][0].any()
    assert peak < 20 * v.size  # the gradients, their sorted copy, the mask


@pytest.mark.parametrize("masked", [False, True])
def test_fit_blocked_sums_equal_the_kernel(monkeypatch, masked):
    """The normal equations as matrix products over blocks of slices (several blocks
    here) give the weights of the kernel's row-by-row sums; a value range whose sums could
    pass 2^53 takes the kernel."""
    rng = np.random.default_rng(11)
    v = np.cumsum(rng.integers(-9, 10, size=(23, 30, 26)), axis=1) + 300
    mask = rng.random(v.shape) < 0.2 if masked else None
    monkeypatch.setattr(predictfit, "FIT_CHUNK", 700)  # 3 slices a block
    blocked = predictfit.fit(v, mask)
    monkeypatch.setattr(predictfit, "FIT_CHUNK", 0)  # no block: the kernel's sums
    want = predictfit.fit(v, mask)
    for (cf, th), (cf0, th0) in zip(blocked, want):
        np.testing.assert_array_equal(cf, cf0)
        np.testing.assert_array_equal(th, th0)
    called = []
    monkeypatch.setattr(predictfit, "FIT_CHUNK", 700)
    monkeypatch.setattr(predictfit, "_fit_blocked", lambda *a: called.append(1))
    predictfit.fit(v << 20, mask)  # products of 2^29: past 2^53 summed
    assert not called
