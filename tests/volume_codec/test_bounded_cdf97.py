"""The bounded codec's float wavelet path: the CDF 9/7 against a naive reference, the
bound on every voxel, special values, edge bounds, and damaged payloads."""

from __future__ import annotations

import numpy as np
import pytest
from naive import cdf97_transform

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec.lossy import FLAG_CDF97, FLAG_OUTLIERS, BoundedCodec
from volpack.wavelet import cdf97, dwt3


def smooth_float(shape, dtype=np.float32, seed=0, noise=0.0):
    r = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 3, n) for n in shape), indexing="ij")
    f = np.sin(z * 1.3 + y) * np.cos(x * 0.7 - y * 0.5) + 0.3 * np.sin(4 * x * z)
    return (f + r.normal(0, noise, shape)).astype(dtype)


def flags_of(blob):
    with Reader(blob) as r:
        return [r.read(e.t, e.node)[0] for e in r.entries]


def check_bound(a, blob, bound):
    got = api.decompress_array(blob)
    ok = np.isfinite(a)
    err = np.abs(got[ok].astype(np.float64) - a[ok].astype(np.float64))
    assert err.max(initial=0.0) <= bound
    np.testing.assert_array_equal(np.isnan(got), np.isnan(a))
    np.testing.assert_array_equal(got[~ok & ~np.isnan(a)], a[~ok & ~np.isnan(a)])
    return got


@pytest.mark.parametrize(
    "shape", [(9, 13, 20), (1, 7, 33), (2, 2, 2), (5, 1, 1), (3, 64, 6), (33, 3, 2)]
)
def test_cdf97_matches_the_naive_reference_bit_for_bit(shape):
    x = np.random.default_rng(3).standard_normal(shape) * 100
    full = dwt3.levels_for_shape(shape, None)
    for lv in {full, (full[0], 0, full[2]), (0, full[1], 0)}:
        c = cdf97.forward(x, lv)
        np.testing.assert_array_equal(c, cdf97_transform(x, lv))
        np.testing.assert_array_equal(cdf97.inverse(c, lv), cdf97_transform(c, lv, True))
        np.testing.assert_allclose(cdf97.inverse(c, lv), x, atol=1e-11)


def test_cdf97_is_nearly_orthonormal_and_keeps_constants_in_one_coefficient():
    x = np.random.default_rng(4).standard_normal((16, 24, 32))
    lv = dwt3.levels_for_shape(x.shape, None)
    c = cdf97.forward(x, lv)
    assert 0.9 < np.sum(c * c) / np.sum(x * x) < 1.2
    c = cdf97.forward(np.full((16, 24, 32), 2.5), lv)
    assert np.count_nonzero(np.abs(c) > 1e-9) == 1


@pytest.mark.parametrize("rel", [3e-2, 1e-2, 1e-3])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_smooth_floats_take_the_wavelet_path_and_hold_the_bound(rel, dtype):
    a = smooth_float((20, 40, 90), dtype, noise=1e-3)
    e = float(a.max() - a.min()) * rel
    blob = api.compress_array(a, max_error=e)
    assert all(f & FLAG_CDF97 for f in flags_of(blob))
    check_bound(a, blob, e)
    old = api.compress_array(a, max_error=e, brick=64)
    assert len(blob) < len(old)  # one brick, long transforms


def test_outliers_are_coded_and_moved_back_within_the_bound():
    a = smooth_float((24, 24, 24), noise=1e-3, seed=5)
    blob = api.compress_array(a, max_error=0.01)
    assert any(f & FLAG_OUTLIERS for f in flags_of(blob))
    check_bound(a, blob, 0.01)


def test_nan_inf_and_fill_are_restored_exactly_on_the_wavelet_path():
    a = smooth_float((18, 30, 40), noise=1e-3)
    a[2, 3:9, 4] = np.nan
    a[5, 5, 5] = -np.inf
    a[6, 7, 8] = np.inf
    a[10:12, :, 20:] = -999.0
    blob = api.compress_array(a, max_error=0.01, fill_value=-999.0)
    assert all(f & FLAG_CDF97 for f in flags_of(blob))
    got = api.decompress_array(blob)
    fill = a == -999.0
    np.testing.assert_array_equal(got[fill], a[fill])
    ok = np.isfinite(a) & ~fill
    assert np.abs(got[ok].astype(np.float64) - a[ok]).max() <= 0.01
    assert np.isnan(got[2, 3:9, 4]).all() and got[5, 5, 5] == -np.inf and got[6, 7, 8] == np.inf


def test_constant_field_and_a_single_spike():
    a = np.full((16, 20, 24), 3.25, np.float32)
    check_bound(a, api.compress_array(a, max_error=1e-3), 1e-3)
    s = smooth_float((16, 20, 24))
    s[8, 10, 12] = 1e6
    blob = api.compress_array(s, max_error=1e-3)
    got = check_bound(s, blob, 1e-3)
    assert got[8, 10, 12] == pytest.approx(1e6, abs=1e-3)


@pytest.mark.parametrize("e", [5e-6, 5e-8, 10.0, 1e6])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_bounds_below_float_spacing_and_above_the_range(e, dtype):
    # Values 50..150: float32's spacing there is 3.8e-6 to 7.6e-6, so 5e-6 and 5e-8 sit
    # below it (the voxels come back exactly or within a float step); 10 and 1e6 are at
    # and above the range.
    a = smooth_float((12, 16, 20), dtype, noise=1e-2) * 50 + 100
    check_bound(a, api.compress_array(a, max_error=e), e)


def test_a_bound_needing_more_than_2_31_bins_is_refused_clearly():
    a = smooth_float((12, 16, 20)) * 50 + 100
    with pytest.raises(ValueError, match="too small for the value range"):
        api.compress_array(a, max_error=1e-12)


def test_a_huge_offset_leaves_the_wavelet_path_to_the_others():
    # The mean coefficient passes 2^50 steps: q would lose integers in float64.
    a = smooth_float((10, 12, 14), np.float64) * 1e3 + 1e15
    blob = api.compress_array(a, max_error=1.0)
    assert not any(f & FLAG_CDF97 for f in flags_of(blob))
    check_bound(a, blob, 1.0)


def test_damaged_wavelet_payloads_raise_format_errors():
    a = smooth_float((24, 24, 24), noise=1e-3, seed=5)
    c = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), 0.01)
    payload = c.encode(a)
    assert payload[0] & FLAG_CDF97
    n = int.from_bytes(payload[1:5], "little")
    bad_levels = bytearray(payload)
    bad_levels[5] = 1  # levels are 0 or full (5 here)
    bad_step = bytearray(payload)
    bad_step[9:17] = np.float64(-1.0).tobytes()
    int_dtype = (payload, np.int16)
    for blob, dtype in [(bytes(bad_levels), a.dtype), (bytes(bad_step), a.dtype), int_dtype]:
        with pytest.raises(FormatError):
            c.decode(blob, a.shape, dtype)
    with pytest.raises(FormatError):
        c.decode(bytes([payload[0] | 4]) + payload[1:], a.shape, a.dtype)
    with pytest.raises(FormatError):
        c.decode(payload + b"\0", a.shape, a.dtype)
    assert n + 5 <= len(payload)
    rng = np.random.default_rng(0)
    for _ in range(40):
        d = bytearray(payload)
        d[rng.integers(0, len(d))] ^= 1 << int(rng.integers(0, 8))
        try:
            out = c.decode(bytes(d), a.shape, a.dtype)
            assert out.shape == a.shape
        except FormatError:
            pass


@pytest.mark.parametrize(
    "shape,density", [((7, 9, 33), 0.03), ((3, 5, 1), 0.5), ((1, 1, 1), 1.0), ((6, 8, 10), 0.0)]
)
def test_bin_field_round_trip_adds_the_bins_as_the_reference_does(shape, density):
    from volpack.volume_codec import bin_field
    from volpack.volume_codec.bounded_cdf97 import add_bins

    rng = np.random.default_rng(7)
    r = np.where(rng.random(shape) < density, rng.choice([-1, 1, 2, -3], shape), 0)
    r.reshape(-1)[: min(3, r.size)] = [2**31 - 1, -(2**30) - 5, 17][: min(3, r.size)]
    base = rng.standard_normal(shape)
    want = base.copy()
    idx = np.flatnonzero(r)
    add_bins(want, idx, r.reshape(-1)[idx], 0.37)
    got = base.copy()
    body = bin_field.encode(r)
    bin_field.add_decoded(body, got, 0.37)
    np.testing.assert_array_equal(got, want)  # bit for bit
    with pytest.raises(FormatError):
        bin_field.add_decoded(body[: max(0, len(body) - 12)], base.copy(), 0.37)


def test_bin_field_codes_clustered_outliers_shorter_than_the_dense_field():
    from volpack.entropy import CODERS
    from volpack.volume_codec import bin_field
    from volpack.wavelet import sigmap

    a = smooth_float((16, 40, 60), np.float64)
    r = np.where(np.abs(a) > 0.95, np.sign(a), 0).astype(np.int64)  # ridges of +-1
    dense = CODERS["arith"].encode(r, sigmap.scan(r.shape, (0, 0, 0), "line"))
    assert len(bin_field.encode(r)) < 0.9 * len(dense)
