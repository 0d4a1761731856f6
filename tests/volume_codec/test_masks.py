"""bool volumes (masks) by the lossless codec (session 32, user32): the default codec
took zstd for them (a brain mask: 133.7:1, below zstd -19's 147.5:1 and half of the same
mask as uint8, 287.8:1); now a bool brick is coded as its bytes, 0 and 1."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import smooth_volume

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec.lossless import LosslessCodec


def mask(shape=(24, 40, 44), seed=0):
    return smooth_volume(shape, np.int16, seed) > 600


def test_a_mask_round_trips_as_bool_and_codes_as_its_uint8_copy():
    m = mask()
    blob = api.compress_array(m, brick=16)
    with Reader(blob) as r:
        assert r.header["codec"]["id"] == "lossless"
    back = api.decompress_array(blob)
    assert back.dtype == np.bool_ and back.shape == m.shape
    np.testing.assert_array_equal(back, m)
    as_u8 = len(api.compress_array(m.astype(np.uint8), brick=16))
    assert len(blob) <= as_u8 + 16, (len(blob), as_u8)
    assert 1.4 * len(blob) < len(api.compress_array(m, brick=16, codec="zstd"))


def test_a_bool_brick_decoding_to_other_values_is_refused():
    c = LosslessCodec()
    payload = c.encode(np.full((4, 4, 4), 2, np.uint8) * (np.arange(4) % 2))
    with pytest.raises(FormatError, match="a value other than 0 and 1"):
        c.decode(payload, (4, 4, 4), np.bool_)
    ok = c.encode(np.arange(64).reshape(4, 4, 4) % 3 == 0)
    np.testing.assert_array_equal(
        c.decode(ok, (4, 4, 4), np.bool_), np.arange(64).reshape(4, 4, 4) % 3 == 0
    )
