"""LOWM (session 39): the low-value class's mantissa bits in models keyed on the
prediction (flag 2048, the second flags byte's bit 3; formats/lossless-1.md step 8.6b)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import flip_bits

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import lossless, predictfit
from volpack.volume_codec.lossless import FLAG_LOW, FLAG_LOWM, FLAG_MORE, LosslessCodec, describe

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"


def floor_band(shape=(12, 32, 32), seed=39):
    """iid uniform noise 0..14 everywhere (a uint8 scan's noise floor), a ball of radius
    9 raised into a narrow band: the golden lossless-v8-u8-lowm example's volume
    (scripts/make_examples.py's lowm_source, written out again on purpose)."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    v = rng.integers(0, 15, size=z.shape)
    c = np.array(shape) // 2
    ball = (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 <= 81
    v[ball] += (70 + 10 * np.sin(x * 0.3) * np.cos(y * 0.2)).astype(np.int64)[ball]
    return v.astype(np.uint8)


@pytest.mark.parametrize("mix", [False, True])
def test_lowm_roundtrips_and_pays_on_a_noise_floor(mix):
    v = floor_band().astype(np.int64)
    for mask in (None, v == 7):  # (a mask marks voxels of one known value)
        fill = int(v[mask].flat[0]) if mask is not None else 0
        low = predictfit.encode(v, 0, 255, mask=mask, low=True, mix=mix)
        lowm = predictfit.encode(v, 0, 255, mask=mask, low=True, mix=mix, lowm=True)
        back = predictfit.decode(lowm, v.shape, 0, 255, mask, fill, low=True, mix=mix, lowm=True)
        np.testing.assert_array_equal(back, v)
        # (measured: 0.975-0.989 of the bytes)
        assert len(lowm) < 0.99 * len(low)


@pytest.mark.parametrize("shape", [(12, 32, 32), (8, 24, 24)])  # the pruned path, _encode_fit
def test_codec_keeps_lowm_where_shorter(monkeypatch, shape):
    a = floor_band(shape)
    with_lowm = LosslessCodec().encode(a)
    assert "+lowm" in describe(with_lowm)
    np.testing.assert_array_equal(LosslessCodec().decode(with_lowm, a.shape, a.dtype), a)
    monkeypatch.setattr(lossless, "LOWM", False)
    without = LosslessCodec().encode(a)
    assert "+lowm" not in describe(without) and len(with_lowm) < len(without)
    # (versions before 8 never try it)
    monkeypatch.setattr(lossless, "LOWM", True)
    assert "+lowm" not in describe(LosslessCodec(predict_version=7).encode(a))


def test_corrupt_lowm_sections_raise_format_error():
    codec = LosslessCodec()
    a = floor_band()
    good = codec.encode(a)
    assert good[1] & FLAG_LOW and good[1] & FLAG_MORE and good[2] & FLAG_LOWM >> 8
    bad = [
        good[:1] + bytes([good[1] & ~FLAG_LOW]) + good[2:],  # LOWM without LOW
        good[:2] + bytes([0x10 | good[2]]) + good[3:],  # an unknown bit
        good[:2] + bytes([FLAG_LOWM >> 8 | 6]) + good[3:],  # LOCAL with PLANE
        good[: len(good) // 2],
        good + b"\x00",
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    flip_bits(codec, bytearray(good), a, np.random.default_rng(39), 10)


def test_golden_lowm_stream_decodes_and_is_reproduced():
    want = floor_band()
    blob = (GOLDEN / "lossless-v8-u8-lowm.vpk").read_bytes()
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    with Reader(blob) as r:
        assert any("+lowm" in describe(bytes(p)) for _, _, p in r if len(p) > 3)
    again = api.compress_array(want, brick=(12, 32, 32))
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
