"""2-D fields and thin stacks under an error bound (session 34): a thin float volume past
LOSSY_FLOAT_VOXELS is cut into bricks of its whole depth (bricks.thin_brick), not into
128^2 tiles of 128^3 bricks."""

from __future__ import annotations

import numpy as np
import pytest

from volpack import api
from volpack.format.container import Reader
from volpack.volume_codec import bricks


def smooth(shape, seed=0):
    """A smooth float32 field (long waves) under a little noise."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape, dtype=np.float64)
    f = np.sin(x * 0.031 + 0.7 * z) * np.cos(y * 0.023 - 0.4 * z) + 0.5 * np.sin((x - y) * 0.011)
    return (f + rng.normal(0, 0.01, shape)).astype(np.float32)


@pytest.fixture
def small_limit(monkeypatch):
    """Past 2^16 voxels a float volume is bricked: thin ones into (nz, 256, 256) and less
    here, so small arrays cross brick edges as a large field's do."""
    monkeypatch.setattr(bricks, "LOSSY_FLOAT_VOXELS", 1 << 16)


def brick_of(blob):
    with Reader(blob) as r:
        return tuple(r.header["brick"]), len(r.entries)


def check_bound(a, blob, rel):
    back = api.decompress_array(blob)
    assert back.shape == a.shape and back.dtype == a.dtype
    ok = np.isfinite(a)
    span = float(np.nanmax(a)) - float(np.nanmin(a))
    err = np.abs(back[ok].astype(np.float64) - a[ok].astype(np.float64))
    assert err.max() <= rel * span, (err.max(), rel * span)
    np.testing.assert_array_equal(np.isnan(back), np.isnan(a))


def test_default_brick_of_thin_float_fields_under_a_bound():
    f4 = np.float32
    assert bricks.default_brick((1, 1800, 3600), f4, True) == (1, 2048, 2048)
    assert bricks.default_brick((4, 1800, 3600), f4, True) == (4, 1024, 1024)
    assert bricks.default_brick((16, 1024, 1024), f4, True) == (16, 512, 512)
    # small ones whole, thicker ones 128^3, exact ones as before
    assert bricks.default_brick((1, 1201, 2401), f4, True) == (1, 1201, 2401)
    assert bricks.default_brick((17, 1024, 1024), f4, True) == (128, 128, 128)
    assert bricks.default_brick((1, 1800, 3600), f4, False, "auto") == (128, 128, 128)
    for nz in range(1, bricks.THIN_SLICES + 1):
        _, s, _ = bricks.thin_brick(nz, bricks.LOSSY_FLOAT_VOXELS)
        assert nz * s * s <= bricks.LOSSY_FLOAT_VOXELS < nz * (2 * s) ** 2


@pytest.mark.parametrize("shape", [(1, 301, 517), (2, 263, 300), (3, 257, 129), (1, 1, 70001)])
@pytest.mark.parametrize("rel", [1e-2, 1e-4])
def test_thin_round_trip_within_the_bound(small_limit, shape, rel):
    a = smooth(shape, sum(shape))
    blob = api.compress_array(a, rel_error=rel)
    brick, n = brick_of(blob)
    assert brick[0] == shape[0] and n > 1, (brick, n)
    check_bound(a, blob, rel)


@pytest.mark.parametrize("shape", [(1, 45, 53), (1, 7, 9), (2, 33, 36), (3, 64, 5)])
def test_small_2d_fields_round_trip(shape):
    a = smooth(shape, 3)
    for rel in (1e-2, 1e-3, 1e-5):
        check_bound(a, api.compress_array(a, rel_error=rel), rel)


def test_nan_in_a_2d_field(small_limit):
    a = smooth((1, 300, 290), 5)
    a[0, 100:140, 30:260] = np.nan  # land in an ocean field, across a brick edge
    a[0, 5, 7] = np.nan
    for rel in (1e-2, 1e-4):
        blob = api.compress_array(a, rel_error=rel)
        assert brick_of(blob)[1] > 1
        check_bound(a, blob, rel)


def test_same_bytes_at_one_and_two_workers(small_limit):
    a = smooth((2, 300, 280), 6)
    one = api.compress_array(a, rel_error=1e-3, workers=1)
    assert brick_of(one) == ((2, 128, 128), 9)
    assert api.compress_array(a, rel_error=1e-3, workers=2) == one


def test_whole_slices_code_shorter_than_tiles(small_limit, monkeypatch):
    """The bricks of 10dcf4d (128^3: 128^2 tiles of a 2-D field) against today's (256^2
    here, small_limit): each tile predicts and codes its edges without its neighbours."""
    a = smooth((1, 512, 512), 7)
    new = api.compress_array(a, rel_error=1e-2)
    monkeypatch.setattr(bricks, "THIN_SLICES", 0)
    old = api.compress_array(a, rel_error=1e-2)
    assert brick_of(old)[0] == (128, 128, 128) and brick_of(new)[0] == (1, 256, 256)
    assert len(new) < 0.8 * len(old), (len(new), len(old))  # 2886 against 4492 bytes


@pytest.mark.slow
def test_a_field_of_the_cesm_grid():
    """A 1800x3600 field (6.5 M voxels) at its real size: two bricks of whole rows."""
    y, x = np.mgrid[0:1800, 0:3600].astype(np.float64)
    a = (np.sin(x / 300) * np.cos(y / 170) + 0.2 * np.sin((x + 2 * y) / 37)).astype(np.float32)[
        None
    ]
    blob = api.compress_array(a, rel_error=1e-3, workers=2)
    assert brick_of(blob) == ((1, 2048, 2048), 2)
    check_bound(a, blob, 1e-3)
