"""Version 9 of the predictive stream (``LOCAL``: the blend weighted against a predictor
refitted along every row, :mod:`volpack.volume_codec.localfit`): the estimates against a
slow reference, round trips on edge cases and masks, what it saves on real scans, the
bounds of its use, corrupt flags, and ``effort='max'``."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import benchmark_volume, flip_bits
from naive import localfit_estimates
from test_predictfit import brain, roundtrip_stream, tissue

from volpack import api
from volpack.errors import FormatError, OptionError
from volpack.volume_codec import localfit, predictfit
from volpack.volume_codec.lossless import FLAG_FIT, FLAG_MORE, MODE_PREDICT, LosslessCodec, describe


def roundtrip_local(v, lo, hi, mask=None, **opts):
    return roundtrip_stream(v, lo, hi, mask=mask, local=True, **opts)


def test_estimates_match_a_slow_reference():
    rng = np.random.default_rng(7)
    for shape in [(5, 9, 11), (6, 12, 8), (4, 6, 30), (3, 5, 5)]:
        z, y, x = np.indices(shape)
        v = (3 * z + 2 * y + x + rng.integers(0, 20, shape)).astype(np.int64)
        got = localfit.estimates(v, predictfit.FIT_OFFSETS)
        want = localfit_estimates(v, predictfit.FIT_OFFSETS)
        has = want != None  # noqa: E711 (an object array)
        assert np.array_equal(got != localfit.NONE, has), shape
        if has.any():  # the same sums, solved by numpy in another order: within an eighth
            diff = np.abs(got[has] - want[has].astype(np.int64))
            assert diff.max() <= 1 and (diff == 0).mean() > 0.95, shape
    cut = brain((16, 64, 80))[8:14, 20:40, 30:60].astype(np.int64)
    got = localfit.estimates(cut, predictfit.FIT_OFFSETS)
    want = localfit_estimates(cut, predictfit.FIT_OFFSETS)
    has = want != None  # noqa: E711
    assert np.array_equal(got != localfit.NONE, has) and has.sum() > 1000
    diff = np.abs(got[has] - want[has].astype(np.int64))
    assert diff.max() <= 1 and (diff == 0).mean() > 0.99


def test_flat_windows_and_short_bricks_have_no_estimate():
    v = np.full((6, 9, 9), 17, dtype=np.int64)
    assert (localfit.estimates(v, predictfit.FIT_OFFSETS) == localfit.NONE).all()
    assert not localfit.usable((2, 30, 30), 255) and not localfit.usable((9, 4, 30), 255)
    assert not localfit.usable((9, 9, 9), 1 << localfit.MAX_BITS)
    assert localfit.usable((3, 5, 5), (1 << localfit.MAX_BITS) - 1)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
@pytest.mark.parametrize("shape", [(3, 5, 5), (4, 6, 30), (9, 17, 13), (12, 9, 6)])
def test_roundtrip_shapes(shape):
    rng = np.random.default_rng(sum(shape))
    z, y, x = np.indices(shape)
    v = (40 + 5 * np.sin(x * 0.7) * y + z + rng.integers(0, 9, shape)).astype(np.int64)
    for opts in ({}, {"mix": True}, {"low": True, "tex": True, "mix": True}):
        roundtrip_local(v, int(v.min()), int(v.max()), **opts)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
def test_roundtrip_extremes_of_the_value_range():
    rng = np.random.default_rng(3)
    top = (1 << localfit.MAX_BITS) - 1
    v = rng.integers(0, 2, (5, 8, 9)) * top  # two values at both ends of the range
    roundtrip_local(v, 0, top)
    w = top - rng.integers(0, 3, (5, 8, 9))  # near the top, with lo far from 0
    roundtrip_local(w, int(w.min()), int(w.max()), mix=True)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
@pytest.mark.parametrize("kind", ["checker", "pairs", "edges", "one", "all-but-one"])
def test_roundtrip_with_masks(kind):
    """Masked voxels skip the refits where two masked voxels share them: the decoder
    must move its sums through them all the same."""
    v = tissue()[:12, :14, :15].astype(np.int64)
    z, y, x = np.indices(v.shape)
    mask = {
        "checker": (z + y + x) % 2 == 0,
        "pairs": (x // 2 + y) % 3 == 0,
        "edges": (x < 3) | (y == 5) | (x >= 12),
        "one": (z == 4) & (y == 6) & (x == 7),
        "all-but-one": ~((z == 4) & (y == 6) & (x == 7)),
    }[kind]
    v = np.where(mask, 90, v)
    roundtrip_local(v, int(v.min()), int(v.max()), mask=mask, mix=True)


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_saves_on_real_scans_and_says_so():
    v = benchmark_volume("brainsmall")[:40]
    v8 = LosslessCodec(predict_version=8)
    v9 = LosslessCodec(predict_version=9)
    a, b = v8.encode(v), v9.encode(v)
    assert len(b) < 0.985 * len(a)  # (2.6 % on the whole volume)
    assert "+local" in describe(b) and "+local" not in describe(a)
    np.testing.assert_array_equal(v9.decode(b, v.shape, v.dtype), v)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
def test_version_8_streams_are_unchanged_by_version_9():
    v = tissue().astype(np.uint8)
    assert LosslessCodec(predict_version=8).encode(v) == LosslessCodec(predict_version=8).encode(v)
    data = LosslessCodec(predict_version=9).encode(v)
    assert describe(data).endswith("+local")
    np.testing.assert_array_equal(LosslessCodec().decode(data, v.shape, v.dtype), v)


def test_out_of_reach_bricks_are_refused_or_skipped():
    v = np.arange(2 * 6 * 6).reshape(2, 6, 6)
    with pytest.raises(OptionError, match="local fit"):
        predictfit.encode(v, 0, int(v.max()), local=True)
    data = predictfit.encode(v, 0, int(v.max()))
    with pytest.raises(FormatError, match="local fit"):
        predictfit.decode(data, v.shape, 0, int(v.max()), local=True)
    big = (np.arange(4 * 6 * 7).reshape(4, 6, 7) * 99991) % (1 << 24)  # a span past 2^20
    data = LosslessCodec(predict_version=9, tools="predict").encode(big.astype(np.int32))
    assert "+local" not in describe(data)
    np.testing.assert_array_equal(LosslessCodec().decode(data, big.shape, np.int32), big)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
def test_corrupt_second_flags_byte_and_bit_flips():
    v = tissue().astype(np.uint8)
    codec = LosslessCodec(predict_version=9, tools="predict")
    good = codec.encode(v)
    assert good[0] == MODE_PREDICT and good[1] & FLAG_FIT and good[1] & FLAG_MORE
    assert good[2] & 2  # LOCAL
    # (4 is PLANE since session 33; 6 PLANE with LOCAL; 8 LOWM since session 39, valid
    # with LOW; 14 LOWM with PLANE and LOCAL)
    for second in (0, 6, 14, 255):
        bad = good[:2] + bytes([second]) + good[3:]
        with pytest.raises(FormatError, match="second flags byte"):
            codec.decode(bad, v.shape, v.dtype)
    flip_bits(codec, good, v, np.random.default_rng(11), 40)


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
def test_effort_max_is_version_10():
    v = tissue().astype(np.uint8)
    a = api.compress_array(v, effort="max")
    b = api.compress_array(v, predict_version=10)  # 10 adds only a float tool
    assert a == b and api.decompress(a).data.tobytes() == v.tobytes()
    assert api.compress_array(v, effort="max", workers=2) == a
    with pytest.raises(OptionError, match="predict_version=10"):
        api.compress_array(v, effort="max", codec="wavelet")


def test_golden_streams_use_the_local_fit():
    from pathlib import Path

    from volpack.format.container import Reader

    golden = Path(__file__).resolve().parents[2] / "formats" / "examples"
    for stem in ("lossless-v9-u8-local", "lossless-v9-u8-local-mask", "lossless-v9-i16-local-palette"):
        with Reader((golden / f"{stem}.vpk").read_bytes()) as r:
            tools = [describe(r.read(e.t, e.node)) for e in r.entries]
        assert tools and all(t.endswith("+mix+local") for t in tools), (stem, tools)
    with Reader((golden / "lossless-v9-u8-local-mask.vpk").read_bytes()) as r:
        assert all("+mask" in describe(r.read(e.t, e.node)) for e in r.entries)
