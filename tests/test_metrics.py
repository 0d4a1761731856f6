"""Error and cost metrics: known values, naive references, no integer wrap-around."""

from __future__ import annotations

import json
import math

import naive
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from volpack import metrics


@pytest.mark.parametrize(
    ("dtype", "lo", "hi"),
    [
        (np.uint8, 0, 255),
        (np.int16, -32768, 32767),
        (np.uint32, 0, 2**32 - 1),
        (np.int64, -(2**63), 2**63 - 1),
        (np.uint64, 0, 2**64 - 1),
    ],
)
def test_max_error_does_not_wrap(dtype, lo, hi):
    a = np.array([[[lo, hi]]], dtype=dtype)
    b = np.array([[[hi, lo]]], dtype=dtype)
    assert metrics.max_error(a, b) == float(hi - lo)
    assert metrics.rmse(a, b) == pytest.approx(float(hi - lo))


def test_psnr_known_values():
    a = np.linspace(0, 100, 101).reshape(1, 1, 101)
    assert metrics.psnr(a, a.copy()) == math.inf
    # a uniform error of 2 over a range of 100: 20 log10(100) - 10 log10(4)
    assert metrics.psnr(a, a + 2) == pytest.approx(40 - 10 * math.log10(4), abs=1e-12)
    assert metrics.psnr(a, a + 2, peak=255) == pytest.approx(
        20 * math.log10(255) - 10 * math.log10(4), abs=1e-12
    )
    u = np.zeros((2, 2, 2), np.uint8)
    u[0, 0, 0] = 255
    v = u.copy()
    v[1, 1, 1] = 255  # one voxel off by 255 out of 8: mse = 255**2 / 8
    assert metrics.psnr(u, v) == pytest.approx(10 * math.log10(8), abs=1e-12)


def test_psnr_constant_original_differs_is_minus_inf():
    a = np.full((2, 2, 2), 7.0)
    assert metrics.psnr(a, a + 1) == -math.inf


@given(
    dtype=st.sampled_from([np.uint8, np.int16, np.int32, np.float32, np.float64]),
    shape=hnp.array_shapes(min_dims=3, max_dims=3, max_side=5),
    seed=st.integers(0, 2**32 - 1),
)
def test_metrics_match_naive(dtype, shape, seed):
    r = np.random.default_rng(seed)
    if np.dtype(dtype).kind == "f":
        a = (r.normal(0, 100, shape)).astype(dtype)
        b = (a + r.normal(0, 3, shape)).astype(dtype)
    else:
        info = np.iinfo(dtype)
        a = r.integers(info.min, info.max, shape, endpoint=True, dtype=dtype)
        b = r.integers(info.min, info.max, shape, endpoint=True, dtype=dtype)
    assert metrics.max_error(a, b) == naive.metric_max_error(a, b)
    assert metrics.rmse(a, b) == pytest.approx(naive.metric_rmse(a, b), rel=1e-12)
    if np.ptp(a) > 0:
        assert metrics.psnr(a, b) == pytest.approx(naive.metric_psnr(a, b), rel=1e-12, abs=1e-9)


def test_chunked_pass_equals_single_pass(monkeypatch):
    r = np.random.default_rng(3)
    a = r.integers(0, 4096, (9, 10, 11)).astype(np.uint16)
    b = r.integers(0, 4096, (9, 10, 11)).astype(np.uint16)
    mask = r.random(a.shape) < 0.3
    whole = metrics.summary(a, b, mask=mask)
    monkeypatch.setattr(metrics, "_CHUNK", 7)
    assert metrics.summary(a, b, mask=mask) == pytest.approx(whole, rel=1e-12)
    keep = ~mask
    assert whole["max_error"] == naive.metric_max_error(a[keep], b[keep])


def test_errors_whose_squares_overflow(monkeypatch):
    """float64 data near 1e300: the squared errors overflow, RMSE and PSNR do not; they
    equal those of the same data scaled down by an exact power of two (chunked too, the
    largest error arriving in a later chunk)."""
    r = np.random.default_rng(5)
    a = r.normal(0, 1, (6, 7, 8))
    b = a + r.normal(0, 1e-2, a.shape)
    b[5, 6, 7] += 0.5  # the largest error in the last chunk
    k = 2.0**990
    small, big = metrics.summary(a, b), metrics.summary(a * k, b * k)
    assert math.isfinite(big["psnr"]) and big["psnr"] == pytest.approx(small["psnr"], rel=1e-12)
    assert big["rmse"] == pytest.approx(small["rmse"] * k, rel=1e-12)
    assert metrics.rmse(a * k, b * k) == big["rmse"]
    assert metrics.psnr(a * k, b * k) == big["psnr"]
    monkeypatch.setattr(metrics, "_CHUNK", 13)
    assert metrics.summary(a * k, b * k) == pytest.approx(big, rel=1e-12)
    assert metrics.summary(a, b) == pytest.approx(small, rel=1e-12)


def test_mask_and_special_values():
    a = np.array([[[np.nan, np.inf, -np.inf, 1.0, 5.0]]])
    b = np.array([[[np.nan, np.inf, -np.inf, 2.0, 100.0]]])
    mask = np.array([[[False, False, False, False, True]]])
    # matching specials are exact; the masked voxel is left out
    assert metrics.max_error(a, b, mask) == 1.0
    assert metrics.rmse(a, b, mask) == pytest.approx(math.sqrt(1 / 4))
    # a special value against a number is an infinite error
    c = b.copy()
    c[0, 0, 0] = 0.0
    assert metrics.max_error(a, c, mask) == math.inf
    assert metrics.psnr(a, c, mask=mask) == -math.inf
    # peak = range of the finite valid voxels of the original (1..5, NaN and Inf left out)
    d = b.copy()
    d[0, 0, 4] = 5.0
    expected = 20 * math.log10(4) - 10 * math.log10(1 / 5)
    assert metrics.psnr(a, d) == pytest.approx(expected, abs=1e-12)
    assert metrics.psnr(a, b, mask=mask) == -math.inf  # one valid finite voxel: no range


def test_empty_and_all_masked():
    e = np.zeros((0, 3, 3), np.float32)
    assert metrics.max_error(e, e) == 0.0 and metrics.rmse(e, e) == 0.0
    a = np.ones((2, 2, 2))
    assert metrics.max_error(a, a + 1, np.ones(a.shape, bool)) == 0.0


def test_mixed_int_and_float_inputs():
    a = np.array([[[0, 255]]], np.uint8)
    b = np.array([[[0.5, 254.0]]], np.float32)
    assert metrics.max_error(a, b) == 1.0


def test_shape_and_dtype_checks():
    with pytest.raises(ValueError, match="same shape"):
        metrics.max_error(np.zeros((1, 1, 2)), np.zeros((1, 2, 1)))
    with pytest.raises(ValueError, match="mask of shape"):
        metrics.rmse(np.zeros((1, 1, 2)), np.zeros((1, 1, 2)), np.zeros(3, bool))
    with pytest.raises(TypeError, match="dtype"):
        metrics.rmse(np.array(["a"]), np.array(["b"]))


def test_cost_metrics():
    assert metrics.ratio(1000, 250) == 4.0
    assert metrics.bits_per_voxel(1000, 4000) == 2.0
    assert metrics.throughput(3_000_000, 1.5) == 2.0
    assert metrics.throughput(10, 0.0) == math.inf
    with pytest.raises(ValueError, match="compressed > 0"):
        metrics.ratio(10, 0)
    with pytest.raises(ValueError, match="nvoxels > 0"):
        metrics.bits_per_voxel(10, 0)
    with pytest.raises(ValueError, match="seconds >= 0"):
        metrics.throughput(10, -1.0)


def test_summary_is_plain_json():
    a = np.arange(64, dtype=np.int16).reshape(4, 4, 4)
    b = a.copy()
    b[1, 2, 3] += 3
    s = metrics.summary(a, b, compressed_nbytes=32)
    assert set(s) == {"psnr", "rmse", "max_error", "ratio", "bpv"}
    assert all(type(v) is float for v in s.values())
    assert s["max_error"] == 3.0 and s["ratio"] == 4.0 and s["bpv"] == 4.0
    assert s["psnr"] == pytest.approx(metrics.psnr(a, b)) and s["rmse"] == metrics.rmse(a, b)
    assert json.loads(json.dumps(s)) == s
    assert "ratio" not in metrics.summary(a, a)
