"""64-bit integer volumes by the lossless codec (session 32, user32): connectomics
segmentations keep uint64 label ids, and numpy's default integer is int64. They were
coded by byte-shuffled zstd alone (a Voronoi segmentation of 128^3: 5.8:1 as uint64
against 55:1 as uint32); now each brick takes the shortest of raw, zstd, its palette's
labels or predicted ranks, and prediction of the values where they fit 32 bits."""

from __future__ import annotations

import os

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec.lossless import LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def segmentation(shape, n, seed, dtype, low, high):
    """Each voxel the id of its nearest of ``n`` random seeds; ids distinct, drawn from
    ``[low, high)`` (0 kept for the background in one corner)."""
    rng = np.random.default_rng(seed)
    pts = rng.integers(0, shape, (n, 3))
    z, y, x = np.indices(shape)
    d = (z[..., None] - pts[:, 0]) ** 2 + (y[..., None] - pts[:, 1]) ** 2
    d += (x[..., None] - pts[:, 2]) ** 2
    ids = np.unique(rng.integers(low, high, 3 * n, dtype=np.uint64))
    ids = rng.permutation(ids)[:n].astype(dtype)
    out = ids[d.argmin(-1)]
    out[:5, :6, :7] = 0
    return out


def smooth_i16(shape, seed):
    z, y, x = np.indices(shape)
    rng = np.random.default_rng(seed)
    f = 900 * np.sin(x * 0.19 + z * 0.07) * np.cos(y * 0.13) - 300 + rng.integers(-3, 4, shape)
    return f.astype(np.int16)


def volumes():
    rng = np.random.default_rng(5)
    wide = rng.integers(-(2**63), 2**63 - 1, (9, 10, 11), dtype=np.int64)
    extremes = np.array([0, 1, 2**63 - 1, 2**63, 2**64 - 1, 12345678901234], np.uint64)
    return {
        "labels u64 past 2^63": segmentation((20, 33, 37), 30, 1, np.uint64, 2**63, 2**64 - 1),
        "labels i64 negative": segmentation((20, 33, 37), 30, 2, np.int64, 0, 2**62) - 2**61,
        "int64 holding int16": smooth_i16((20, 33, 37), 3).astype(np.int64),
        "uint64 holding 32 bits": smooth_i16((20, 33, 37), 4).astype(np.uint64) + 2**31,
        "wide noise": wide,
        "the extremes": rng.choice(extremes, (18, 19, 20)),
        "constant": np.full((17, 18, 19), 2**63 + 7, np.uint64),
    }


@pytest.mark.parametrize("name", list(volumes()))
def test_64_bit_volumes_round_trip_exactly(name):
    a = volumes()[name]
    blob = api.compress_array(a, brick=16)
    with Reader(blob) as r:
        assert r.header["codec"]["id"] == "lossless"
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype and back.shape == a.shape
    assert back.tobytes() == a.tobytes()


def test_a_uint64_segmentation_codes_about_as_short_as_its_uint32_copy():
    """The ids cost the same whatever their width: before, uint64 went to zstd and was
    several times longer."""
    seg = segmentation((32, 48, 48), 60, 7, np.uint32, 1, 2**32 - 1)
    u32 = len(api.compress_array(seg))
    u64 = len(api.compress_array(seg.astype(np.uint64)))
    zstd = len(api.compress_array(seg.astype(np.uint64), codec="zstd"))
    assert u64 <= 1.1 * u32 + 64, (u64, u32)
    assert 3 * u64 < zstd, (u64, zstd)


def test_an_int64_volume_holding_16_bit_values_codes_as_its_int16_copy():
    a = smooth_i16((24, 40, 44), 8)
    i16 = len(api.compress_array(a))
    i64 = len(api.compress_array(a.astype(np.int64)))
    assert i64 <= 1.05 * i16 + 64, (i64, i16)


def test_64_bit_streams_are_the_same_at_one_and_two_workers():
    a = volumes()["labels u64 past 2^63"]
    assert api.compress_array(a, brick=16, workers=1) == api.compress_array(a, brick=16, workers=2)


@pytest.mark.parametrize("mode", [0, 5, 8])  # (7: mode 7, mirrored halves, since session 37)
def test_a_64_bit_brick_of_an_unknown_mode_is_refused(mode):
    with pytest.raises(FormatError, match="lossless int64 brick payload: expected mode 1 to 4, 6 or 7"):
        LosslessCodec().decode(bytes([mode]) + bytes(64), (2, 2, 2), np.int64)


def golden_labels_u64():
    """scripts/make_examples.py's recipe 'labels-u64', written out again on purpose."""
    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    lab = np.digitize(cut, [40, 90])
    lab[:16, :16, :16] = 0
    ids = np.array([0, 2**63 + 12345, 9876543210987], np.uint64)
    out = ids[lab]
    out[16:, 16:, 16:] = (cut[16:, 16:, 16:].astype(np.uint64) << np.uint64(40)) + 7
    return out


def test_golden_uint64_labels_stream_decodes_and_is_reproduced():
    with open(os.path.join(GOLDEN, "lossless-labels-u64.vpk"), "rb") as f:
        blob = f.read()
    want = golden_labels_u64()
    got = api.decompress_array(blob)
    assert got.dtype == want.dtype
    np.testing.assert_array_equal(got, want)
    with Reader(blob) as r:
        modes = {r.read(e.t, e.node)[0] for e in r.entries}
    assert {2, 4} <= modes, modes  # a constant brick and palettes
    again = api.compress_array(want, brick=16)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
