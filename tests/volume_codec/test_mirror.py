"""Mirrored halves (session 37, mode 7): a brick that is its own mirror image along axes
(a formula's field on a grid centred on the origin) coded as its first half."""

from __future__ import annotations

import os

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import lossless, mirror
from volpack.volume_codec.lossless import MODE_MIRROR, MODE_REPEAT, LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def orbital(shape=(15, 16, 18), odd_x=True):
    """|psi|^2 of a 3d and a 2p orbital on a grid centred on the origin, uint8: its own
    mirror image along z and y, and along x too unless ``odd_x``."""
    z, y, x = np.meshgrid(*(np.linspace(-10.0, 10.0, n) for n in shape), indexing="ij")
    r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
    psi = r**2 * np.exp(-r / 3) * (3 * (z / r) ** 2 - 1) / 81
    psi = psi + (0.05 * x * np.exp(-r / 2) if odd_x else 0)
    return np.rint(255 * psi**2 / (psi**2).max()).astype(np.uint8)


def tools(blob):
    with Reader(blob) as r:
        return r.summary.get("tools", {})


def test_a_mirrored_brick_is_coded_as_its_half():
    """session 37's held-out hydrogen atom (0.684x zstd-19) in small: the brick takes mode
    7 along z and y and comes back exactly, far shorter than without it."""
    a = orbital()
    assert mirror.find(a) == 0b011
    saved = lossless.MIRROR
    try:
        lossless.MIRROR = False
        before = api.compress_array(a)
    finally:
        lossless.MIRROR = saved
    after = api.compress_array(a)
    np.testing.assert_array_equal(api.decompress_array(after), a)
    assert any(t.startswith("mirror+") for t in tools(after))
    assert len(after) < 0.6 * len(before)


@pytest.mark.parametrize("dtype", [np.int16, np.float32])
def test_mirror_round_trips_every_axis_and_length(dtype):
    rng = np.random.default_rng(1)
    for shape in [(5, 6, 7), (4, 1, 9), (2, 3, 2)]:
        for axes in range(1, 8):
            if any(axes >> ax & 1 and n < 2 for ax, n in enumerate(shape)):
                continue
            small = rng.integers(-300, 300, size=mirror.shape_of(shape, axes)).astype(dtype)
            full = mirror.expand(small, axes, shape)
            assert full.shape == shape
            for ax in range(3):  # slice i is slice n - 1 - i along each mirrored axis
                if axes >> ax & 1:
                    np.testing.assert_array_equal(full, np.flip(full, ax))
            assert mirror.find(full) & axes == axes
            np.testing.assert_array_equal(mirror.shrink(full, axes), small)
            codec = LosslessCodec()
            np.testing.assert_array_equal(codec.decode(codec.encode(full), shape, dtype), full)


def test_an_asymmetric_brick_and_old_versions_do_not_take_mode_7():
    a = orbital()
    a[3, 4, 5] += 1  # one voxel breaks both symmetries
    assert mirror.find(a) == 0
    assert not any(t.startswith("mirror") for t in tools(api.compress_array(a)))
    b = orbital()
    assert not any(t.startswith("mirror") for t in tools(api.compress_array(b, predict_version=7)))


def test_damaged_mirror_payloads_are_refused():
    a = orbital()
    codec = LosslessCodec()
    payload = codec.encode(a)
    assert payload[:2] == bytes([MODE_MIRROR, 0b011])
    assert lossless.inner_mode(payload) == payload[2] not in (MODE_MIRROR, MODE_REPEAT)
    bad = [
        bytes([MODE_MIRROR, 0]) + payload[2:],  # no axis
        bytes([MODE_MIRROR, 8]) + payload[2:],  # no such axis
        bytes([MODE_MIRROR, 0b011]) + payload,  # nested
        payload[:1],  # no axes byte
        bytes([MODE_MIRROR, 0b111]) + payload[2:],  # the cut shape is not the payload's
    ]
    for damaged in bad:
        with pytest.raises(FormatError):
            codec.decode(damaged, a.shape, a.dtype)
    with pytest.raises(FormatError):  # a mirrored axis of one slice
        codec.decode(bytes([MODE_MIRROR, 0b001]) + payload[2:], (1,) + a.shape[1:], a.dtype)


def test_golden_mirror_stream_decodes_and_is_reproduced():
    """scripts/make_examples.py's recipe 'mirror-u8', written out again on purpose."""
    z, y, x = np.meshgrid(*(np.linspace(-12.0, 12.0, n) for n in (31, 32, 32)), indexing="ij")
    r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
    psi = r**2 * np.exp(-r / 3) * (3 * (z / r) ** 2 - 1) / 81 + 0.05 * x * np.exp(-r / 2)
    want = np.rint(255 * psi**2 / (psi**2).max()).astype(np.uint8)
    with open(os.path.join(GOLDEN, "lossless-v8-u8-mirror.vpk"), "rb") as f:
        blob = f.read()
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    assert any(t.startswith("mirror+") for t in tools(blob))
    again = api.compress_array(want, brick=(31, 32, 32))
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
