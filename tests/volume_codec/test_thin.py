"""Thin volumes (session 33): bricks of a thin volume's whole depth, and the planar
stream (flag 1024: a brick's slices coded as one plane by an in-plane fitted predictor)."""

from __future__ import annotations

import os

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader
from volpack.volume_codec import bricks, lossless, predictfit
from volpack.volume_codec.lossless import FLAG_MORE, FLAG_PLANE, LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def thick_slices(shape, dtype, seed=0):
    """Waves that change from slice to slice (thick slices: little to gain along z)
    under noise, scaled into ``dtype``."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    f = np.sin(x * 0.11 + 1.3 * z) * np.cos(y * 0.07 - 0.8 * z) + 0.3 * np.sin((x + y) * 0.05)
    f = f + rng.normal(0, 0.02, shape)
    info = np.iinfo(dtype)
    lo, hi = max(info.min, -3000), min(info.max, 60000)
    return np.clip(np.round((f + 1.5) / 3 * (hi - lo) * 0.8 + lo), info.min, info.max).astype(dtype)


def old_and_new(a, **opts):
    """The default stream of f0fa4af (no thin bricks, no planar stream) and today's."""
    saved = bricks.THIN_SLICES, lossless.PLANE_SLICES
    bricks.THIN_SLICES, lossless.PLANE_SLICES = 0, -1
    try:
        old = api.compress_array(a, **opts)
    finally:
        bricks.THIN_SLICES, lossless.PLANE_SLICES = saved
    return old, api.compress_array(a, **opts)


def tools(blob):
    return api.info(blob)["summary"]["tools"]


@pytest.mark.parametrize(
    "shape,dtype",
    [
        ((1, 65, 67), np.int16),
        ((2, 66, 80), np.uint8),
        ((3, 80, 65), np.uint16),
        ((5, 70, 91), np.int8),
        ((1, 300, 201), np.uint16),
        ((2, 131, 129), np.int32),
        ((1, 1, 5000), np.int16),  # one row: no voxel has the planar neighbours
        ((4, 2, 2100), np.uint8),  # rows shorter than the planar reach
        ((2, 4100, 1), np.int16),  # one column
    ],
)
def test_thin_round_trip(shape, dtype):
    a = thick_slices(shape, dtype)
    blob = api.compress_array(a)
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype
    np.testing.assert_array_equal(back, a)


def test_thick_slices_take_the_planar_stream_and_gain():
    a = thick_slices((2, 120, 130), np.int16)
    old, new = old_and_new(a)
    assert any(k.endswith("+plane") for k in tools(new)), tools(new)
    assert len(new) < 0.99 * len(old)
    np.testing.assert_array_equal(api.decompress_array(new), a)


def test_planar_stream_never_longer_than_the_old_one():
    """The bound: the encoder keeps the planar stream only where shorter, brick by brick,
    and a thin volume's bricks of whole slices are not longer here either."""
    for seed, shape in enumerate([(1, 200, 230), (3, 150, 170), (8, 90, 140)]):
        a = thick_slices(shape, np.uint16, seed)
        old, new = old_and_new(a)
        assert len(new) <= len(old), (shape, len(new), len(old))
        brick = a[:, :100, :100]
        saved = lossless.PLANE_SLICES
        lossless.PLANE_SLICES = -1
        try:
            without = LosslessCodec().encode(brick)
        finally:
            lossless.PLANE_SLICES = saved
        assert len(LosslessCodec().encode(brick)) <= len(without)


def test_thin_bricks_same_bytes_at_one_and_two_workers():
    a = thick_slices((3, 600, 130), np.int16, 4)
    one = api.compress_array(a, workers=1)
    with Reader(one) as r:
        assert r.header["brick"] == [3, 512, 512] and len(r.entries) == 2
    assert api.compress_array(a, workers=2) == one


def test_default_brick_of_thin_volumes():
    i16 = np.int16
    assert bricks.default_brick((1, 256, 256), i16, False, "auto") == (1, 1024, 1024)
    assert bricks.default_brick((8, 256, 256), i16, False, "lossless") == (8, 256, 256)
    assert bricks.default_brick((12, 1024, 1024), i16, False, "auto") == (12, 256, 256)
    assert bricks.default_brick((3, 100, 300), i16, False, "auto") == (3, 512, 512)
    # thicker, or no wider than the brick, or lossy, or not the default codec: as before
    assert bricks.default_brick((17, 300, 300), i16, False, "auto") == (128, 128, 128)
    assert bricks.default_brick((10, 128, 128), i16, False, "auto") == (128, 128, 128)
    assert bricks.default_brick((1, 256, 256), i16, False, "auto", lossy=True) == (64, 64, 64)
    assert bricks.default_brick((1, 256, 256), i16, False, "zstd") == (64, 64, 64)
    assert bricks.default_brick((1, 256, 256), np.float32, False, "auto") == (128, 128, 128)
    for nz in range(1, bricks.THIN_SLICES + 1):
        _, s, _ = bricks.thin_brick(nz)
        assert nz * s * s <= bricks.THIN_VOXELS < nz * (2 * s) ** 2


@pytest.mark.parametrize("opts", [{}, {"low": True, "tex": True, "mix": True}])
def test_predictfit_plane_round_trip_with_a_mask(opts):
    a = thick_slices((3, 40, 50), np.int16).astype(np.int64)
    mask = np.zeros(a.shape, bool)
    mask[:, :10] = True
    a[mask] = a.min()
    lo, hi = int(a.min()), int(a.max())
    fits = predictfit.fit_plane(a - lo, mask)
    blob = predictfit.encode(a, lo, hi, mask=mask, fitted=fits[0], plane=True, **opts)
    back = predictfit.decode(blob, a.shape, lo, hi, mask, lo, plane=True, **opts)
    np.testing.assert_array_equal(back, a)
    plain = predictfit.encode(a, lo, hi, plane=True, **opts)
    np.testing.assert_array_equal(predictfit.decode(plain, a.shape, lo, hi, plane=True, **opts), a)


def test_planar_fit_against_naive_least_squares():
    """One class: the weights of the normal equations are those of the rows' own least
    squares (to the rounding of 2^-12)."""
    v = thick_slices((2, 30, 40), np.uint8, 3).astype(np.int64)
    plane = v.reshape(-1, v.shape[2])
    rows, target = [], []
    r = predictfit.PLANE_REACH
    for y in range(r, plane.shape[0]):
        for x in range(r, plane.shape[1] - r):
            taps = [plane[y - dy, x - dx] for dy, dx in predictfit.PLANE_OFFSETS]
            if any(t != plane[y, x] for t in taps):
                rows.append(taps)
                target.append(plane[y, x])
    w, *_ = np.linalg.lstsq(np.array(rows, float), np.array(target, float), rcond=None)
    want = np.round(w * (1 << predictfit.CF_BITS))
    got = predictfit.fit_plane(v)[1][0][: predictfit.NFIT]
    assert np.abs(got - want).max() <= 1


def test_planar_stream_refuses_the_local_fit():
    a = thick_slices((2, 20, 20), np.int16).astype(np.int64)
    lo, hi = int(a.min()), int(a.max())
    with pytest.raises(OptionError):
        predictfit.encode(a, lo, hi, plane=True, local=True)
    blob = predictfit.encode(a, lo, hi, plane=True)
    with pytest.raises(FormatError):
        predictfit.decode(blob, a.shape, lo, hi, plane=True, local=True)


def test_damaged_second_flags_byte_is_refused():
    a = thick_slices((2, 120, 130), np.int16)
    payload = LosslessCodec().encode(a)
    assert payload[1] & FLAG_MORE and payload[2] & FLAG_PLANE >> 8
    for bad in (FLAG_PLANE >> 8 | 2, 8, 0):  # PLANE with LOCAL, an unknown bit, none
        damaged = payload[:2] + bytes([bad]) + payload[3:]
        with pytest.raises(FormatError):
            LosslessCodec().decode(damaged, a.shape, a.dtype)


def test_golden_planar_stream_decodes_and_is_reproduced():
    """scripts/make_examples.py's recipe 'thin-i16', written out again on purpose."""
    from volpack.demo import load_demo_volume

    want = load_demo_volume().data[30:54:12, 20:100, 16:112].astype(np.int16) - 100
    with open(os.path.join(GOLDEN, "lossless-v8-i16-plane.vpk"), "rb") as f:
        blob = f.read()
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    assert tools(blob) == {"predict2+mask+low+tex+mix+plane": 1}
    again = api.compress_array(want, brick=(2, 80, 96))
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_planar_stream_with_a_background_mask(monkeypatch):
    """The mask section of a planar payload is coded over the plane (the golden stream
    has one too): the whole planar chain, masked where shorter."""
    a = thick_slices((2, 120, 130), np.uint8, 5)
    z, y, x = np.indices(a.shape)
    a[(y - 60) ** 2 + (x - 65) ** 2 > 50**2] = a.min()
    v = a.astype(np.int64)
    monkeypatch.setattr(lossless, "PRUNE", False)
    (payload,) = lossless._encode_plane(v, int(v.min()), int(v.max()), 8, None)
    assert payload[1] & lossless.FLAG_MASK and payload[2] & FLAG_PLANE >> 8
    np.testing.assert_array_equal(LosslessCodec().decode(payload, a.shape, a.dtype), a)
