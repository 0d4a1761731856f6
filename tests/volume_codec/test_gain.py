"""Gain combs (session 38, mode 8): integers that are a count times a gain plus a little
noise (a photon-counting detector's frames) coded as the counts and the residues apart."""

from __future__ import annotations

import os

import numpy as np
import pytest

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import gain, lossless
from volpack.volume_codec.lossless import MODE_GAIN, MODE_MIRROR, MODE_PREDICT, LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def frames(n=12, size=32, gain_=30, seed=38, dtype=np.int16, pedestal=0):
    """scripts/make_examples.py's recipe 'gain-i16' (with its defaults), written out
    again on purpose: photons of a ring (Poisson) times the gain, read noise sigma 3."""
    rng = np.random.default_rng(seed)
    yy, xx = np.meshgrid(np.arange(size) - 15.5, np.arange(size) - 15.5, indexing="ij")
    lam = 0.3 + 2.0 * np.exp(-(((np.hypot(yy, xx) - 9) / 2) ** 2))
    v = rng.poisson(lam, size=(n, size, size)) * gain_ + np.rint(rng.normal(0, 3, (n, size, size)))
    v[:, 3, 7] = 0  # a dead pixel
    return (v + pedestal).astype(dtype)


def tools(blob):
    with Reader(blob) as r:
        return r.summary.get("tools", {})


def test_detector_frames_take_mode_8_and_are_shorter():
    """session 38's exafel_i16 in small: the comb of period 30 is found, the brick takes
    mode 8, comes back exactly and is shorter than without it (off: GAIN = False)."""
    a = frames()
    assert gain.find(a) == (30, 15)
    codec = LosslessCodec()
    payload = codec.encode(a)
    assert payload[0] == MODE_GAIN
    np.testing.assert_array_equal(codec.decode(payload, a.shape, a.dtype), a)
    assert lossless.inner_mode(payload) == MODE_PREDICT
    assert lossless.describe(payload).startswith("gain+")
    old = lossless.GAIN
    try:
        lossless.GAIN = False
        without = codec.encode(a)
    finally:
        lossless.GAIN = old
    assert without[0] != MODE_GAIN and len(payload) < 0.96 * len(without)


@pytest.mark.parametrize(
    "dtype, pedestal", [(np.uint16, 1000), (np.int16, -20000), (np.int32, 5), (np.uint8, 0)]
)
def test_split_and_join_round_trip_on_every_integer_dtype(dtype, pedestal):
    g = 30 if dtype != np.uint8 else 12
    a = frames(gain_=g, dtype=np.int64, pedestal=pedestal)
    a = np.clip(a, np.iinfo(dtype).min, np.iinfo(dtype).max).astype(dtype)
    a.flat[0], a.flat[1] = np.iinfo(dtype).min, np.iinfo(dtype).max  # the dtype's ends
    for s in (0, g // 2, g - 1):
        k, r = gain.split(a, g, s)
        assert k.dtype == r.dtype == a.dtype and r.min() >= 0 and r.max() < g
        np.testing.assert_array_equal(gain.join(k, r, g, s, a.dtype), a)


def test_no_comb_in_scans_labels_or_a_ramp():
    """A smooth noisy field, a label map (values at multiples of 10) and a ramp: no comb."""
    rng = np.random.default_rng(1)
    smooth = np.rint(
        1000 + 300 * np.sin(np.arange(8 * 32 * 32) / 500.0) + rng.normal(0, 20, 8 * 32 * 32)
    )
    labels = rng.integers(0, 12, size=(8, 32, 32)) * 10
    ramp = np.arange(8 * 32 * 32) % 4000
    for a in (smooth.reshape(8, 32, 32), labels, ramp.reshape(8, 32, 32)):
        assert gain.find(a.astype(np.int16)) is None


def test_damaged_gain_payloads_are_refused():
    a = frames()
    codec = LosslessCodec()
    payload = codec.encode(a)
    g, s, pos, n = gain.unpack(memoryview(payload)[1:])
    body = payload[1 + pos :]
    bad = [
        payload[:1],  # no numbers
        bytes([MODE_GAIN, 1, 0]) + payload[3:],  # a gain of 1
        bytes([MODE_GAIN, 30, 30]) + payload[3:],  # a shift of g
        payload[: 1 + pos + n // 2],  # k's payload cut short
        bytes([MODE_GAIN])
        + gain.pack(g, s, bytes([MODE_MIRROR, 1]) + body[:n])
        + body[n:],  # nested
        bytes([MODE_GAIN]) + gain.pack(7, s, body[:n]) + body[n:],  # r reaches past g = 7
    ]
    for damaged in bad:
        with pytest.raises(FormatError):
            codec.decode(damaged, a.shape, a.dtype)
    with pytest.raises(FormatError, match="a value outside uint8"):
        gain.join(np.full(3, 20, np.uint8), np.zeros(3, np.uint8), 30, 0, np.dtype(np.uint8))


def test_golden_gain_stream_decodes_and_is_reproduced(monkeypatch):
    """Reproduced without LOWM (session 39): since, its residues (the low-value class)
    take LOWM too (formats/examples/lossless-v8-u8-lowm.vpk fixes LOWM)."""
    want = frames()
    with open(os.path.join(GOLDEN, "lossless-v8-i16-gain.vpk"), "rb") as f:
        blob = f.read()
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    assert any(t.startswith("gain+") for t in tools(blob))
    now = api.compress_array(want, brick=(12, 32, 32))
    assert any(t.startswith("gain+") and t.endswith("+lowm") for t in tools(now))
    np.testing.assert_array_equal(api.decompress_array(now), want)
    monkeypatch.setattr(lossless, "LOWM", False)
    again = api.compress_array(want, brick=(12, 32, 32))
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_teeth_off_the_centre_or_wide_are_not_a_comb():
    """session 38's held-out MR angiography passed the other rules in two bricks with
    teeth 0.08-0.21 g off the fold's centre and spreads up to 0.34 g: each tooth must sit
    within g / 16 of the centre with a spread of at most g / 6 (detector frames: 0.01 g,
    0.1 g)."""
    g, rng = 30, np.random.default_rng(3)
    ok = np.rint(rng.normal(g // 2, 3, 2000)).astype(np.int64)
    t = np.repeat([0, 1], 1000)
    w = np.ones(2000)
    assert gain._centred(ok, t, w, np.array([0, 1]), g)
    off = ok.copy()
    off[1000:] += 5  # the second tooth 5 = 0.17 g off
    assert not gain._centred(off, t, w, np.array([0, 1]), g)
    wide = np.rint(rng.normal(g // 2, 6, 2000)).astype(np.int64)  # a spread of 0.2 g
    assert not gain._centred(wide, t, w, np.array([0, 1]), g)
