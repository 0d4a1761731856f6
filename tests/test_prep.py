"""Preprocessing: geometry bookkeeping, filters against naive loops, exact special values,
quantisation error bounds."""

from __future__ import annotations

import math

import naive
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from volpack import prep
from volpack.errors import FormatError
from volpack.volume import Volume


def vol(data, spacing=(2.0, 0.5, 1.0), origin=(10.0, -3.0, 0.25), **kw) -> Volume:
    return Volume(np.asarray(data), spacing=spacing, origin=origin, **kw)


# --- ranges, crop, pad, window ---------------------------------------------------------


def test_parse_ranges_like_numpy():
    shape = (108, 256, 256)
    got = prep.parse_ranges("10:90, :, -6:", shape)
    assert got == (slice(10, 90), slice(0, 256), slice(250, 256))
    assert prep.parse_ranges(",5,-1", shape) == (slice(0, 108), slice(5, 6), slice(255, 256))
    assert prep.parse_ranges(":-8,0:256,:", shape)[0] == slice(0, 100)
    # a 4-D shape: three parts leave time whole, four parts cut it too
    assert prep.parse_ranges("1:2,:,:", (5, 3, 4, 4)) == (
        slice(0, 5),
        slice(1, 2),
        slice(0, 4),
        slice(0, 4),
    )
    assert prep.parse_ranges("3:,:,:,:", (5, 3, 4, 4))[0] == slice(3, 5)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("10:900,:,:", "crop 10:900 on axis z of length 108"),
        (":,300:,:", "on axis y of length 256"),
        ("5:5,:,:", "start < stop"),
        ("-200:,:,:", "axis z"),
        ("a:b,:,:", "integers on axis z"),
        ("1:2:3,:,:", "START:STOP"),
        (":,:", "expected 3 comma-separated ranges"),
    ],
)
def test_parse_ranges_errors(text, match):
    with pytest.raises(FormatError, match=match):
        prep.parse_ranges(text, (108, 256, 256), what="crop")


def test_crop_shifts_origin_and_matches_slicing():
    a = np.arange(6 * 7 * 8, dtype=np.int16).reshape(6, 7, 8)
    v = vol(a, meta={"note": "x"})
    c = prep.crop(v, "1:5,-3:,2:3")
    np.testing.assert_array_equal(c.data, a[1:5, 4:, 2:3])
    assert c.origin == (10.0 + 1 * 2.0, -3.0 + 4 * 0.5, 0.25 + 2 * 1.0)
    assert c.spacing == v.spacing and c.meta == {"note": "x"}
    same = prep.crop(v, (slice(1, 5), slice(4, None), slice(2, 3)))
    np.testing.assert_array_equal(same.data, c.data)
    assert same.origin == c.origin
    with pytest.raises(ValueError, match="step 1"):
        prep.crop(v, (slice(0, 6, 2), slice(None), slice(None)))


def test_crop_of_animation_keeps_time():
    a = np.arange(3 * 4 * 5 * 6, dtype=np.float32).reshape(3, 4, 5, 6)
    c = prep.crop(vol(a), "1:3,:,2:")
    np.testing.assert_array_equal(c.data, a[:, 1:3, :, 2:])
    assert c.origin == (12.0, -3.0, 2.25)


@pytest.mark.parametrize("mode", ["edge", "constant"])
def test_pad_then_crop_round_trip(mode):
    r = np.random.default_rng(1)
    a = r.integers(-500, 500, (3, 4, 5)).astype(np.int16)
    v = vol(a)
    p = prep.pad(v, [(1, 2), (0, 3), (2, 0)], mode=mode, value=-7)
    assert p.shape == (6, 7, 7)
    assert p.origin == (10.0 - 2.0, -3.0, 0.25 - 2.0)
    if mode == "constant":
        assert p.data[0].tolist() == np.full((7, 7), -7).tolist()
    else:
        np.testing.assert_array_equal(p.data[0, :4, 2:], a[0])  # edge copies of the first plane
        np.testing.assert_array_equal(p.data[:, :, 0], p.data[:, :, 2])
    back = prep.crop(p, "1:4,0:4,2:7")
    np.testing.assert_array_equal(back.data, a)
    assert back.origin == v.origin


def test_pad_checks():
    v = vol(np.zeros((2, 2, 2), np.uint8))
    assert prep.pad(v, 1).shape == (4, 4, 4)
    assert prep.pad(v, (1, 0, 2)).shape == (4, 2, 6)
    with pytest.raises(ValueError, match="holds"):
        prep.pad(v, 1, mode="constant", value=300)
    with pytest.raises(ValueError, match="non-negative"):
        prep.pad(v, -1)
    with pytest.raises(ValueError, match="mode"):
        prep.pad(v, 1, mode="wrap")


def test_pad_to_multiple():
    v = vol(np.ones((5, 8, 1), np.float32))
    p = prep.pad_to_multiple(v, 4)
    assert p.shape == (8, 8, 4) and p.origin == v.origin and (p.data == 1).all()
    assert prep.pad_to_multiple(v, (1, 3, 2)).shape == (5, 9, 2)
    a4 = prep.pad_to_multiple(vol(np.zeros((2, 3, 3, 3))), 2)
    assert a4.shape == (2, 4, 4, 4)


def test_window_clamps():
    a = np.array([[[-5, 0, 7, 100]]], dtype=np.int16)
    w = prep.window(vol(a), -0.5, 7.9)
    assert w.data.tolist() == [[[0, 0, 7, 7]]] and w.dtype == np.int16
    f = np.array([[[-5.0, np.nan, 3.0]]], dtype=np.float32)
    g = prep.window(vol(f), 0, 1)
    assert g.dtype == np.float32
    np.testing.assert_array_equal(g.data, np.array([[[0.0, np.nan, 1.0]]], np.float32))
    big = prep.window(vol(np.array([[[np.inf, 1.0]]], np.float32)), -1e300, 1e300)
    assert big.data.tolist() == [[[float(np.finfo(np.float32).max), 1.0]]]
    u = prep.window(vol(np.array([[[0, 255]]], np.uint8)), -1000, 1000)
    assert u.data.tolist() == [[[0, 255]]]
    with pytest.raises(ValueError, match="lo <= hi"):
        prep.window(vol(a), 3, 2)
    with pytest.raises(ValueError, match="holding an integer"):
        prep.window(vol(a), 1.2, 1.8)


# --- downsample and resample -----------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.float32, np.float64])
@pytest.mark.parametrize("factor", [2, 3])
@pytest.mark.parametrize("shape", [(5, 4, 7), (1, 3, 2), (6, 6, 6)])
def test_box_downsample_matches_naive(dtype, factor, shape):
    r = np.random.default_rng(factor * 100 + sum(shape))
    if np.dtype(dtype).kind == "f":
        a = r.normal(0, 50, shape).astype(dtype)
    else:
        a = r.integers(0, 200, shape).astype(dtype)
    d = prep.downsample(vol(a), factor)
    ref = naive.prep_downsample(a, factor, "box")
    assert d.dtype == dtype and d.shape == ref.shape
    if np.dtype(dtype).kind == "f":
        np.testing.assert_allclose(d.data, ref, rtol=1e-6 if dtype == np.float32 else 1e-12)
    else:
        np.testing.assert_array_equal(d.data, ref)


@pytest.mark.parametrize("dtype", [np.int16, np.float64])
@pytest.mark.parametrize(("factor", "shape"), [(2, (5, 4, 7)), (3, (4, 7, 3)), (2, (1, 1, 3))])
def test_gaussian_downsample_matches_naive(dtype, factor, shape):
    r = np.random.default_rng(7)
    a = (r.normal(0, 300, shape)).astype(dtype)
    d = prep.downsample(vol(a), factor, method="gaussian")
    ref = naive.prep_downsample(a, factor, "gaussian")
    assert d.dtype == dtype and d.shape == ref.shape
    if dtype == np.float64:
        np.testing.assert_allclose(d.data, ref, rtol=1e-12, atol=1e-9)
    else:
        # rounding may only differ where the exact value sits on a .5 tie
        exact = naive.prep_gaussian_float(a, factor)
        off = d.data != ref
        assert np.abs(d.data.astype(int) - ref.astype(int)).max(initial=0) <= 1
        assert np.all(np.abs(np.abs(exact[off] - np.floor(exact[off])) - 0.5) < 1e-9)


def test_downsample_rounds_half_to_even_and_keeps_geometry():
    a = np.array([[[1, 2, 2, 3, 9]]], dtype=np.uint8)  # means 1.5, 2.5, 9
    d = prep.downsample(vol(a, spacing=(1, 1, 0.5), origin=(0, 0, 4.0)), (1, 1, 2))
    assert d.data.tolist() == [[[2, 2, 9]]]
    assert d.spacing == (1.0, 1.0, 1.0) and d.origin == (0.0, 0.0, 4.25)
    v = vol(np.zeros((4, 4, 4)))
    e = prep.downsample(v, 2)
    assert e.spacing == (4.0, 1.0, 2.0)
    assert e.origin == (10.0 + 0.5 * 2.0, -3.0 + 0.5 * 0.5, 0.25 + 0.5 * 1.0)


def test_downsample_animation_leaves_time_axis():
    r = np.random.default_rng(2)
    a = r.integers(0, 1000, (3, 5, 4, 3)).astype(np.uint16)
    d = prep.downsample(vol(a), 2, method="gaussian")
    assert d.shape == (3, 3, 2, 2)
    for t in range(3):
        np.testing.assert_array_equal(d.data[t], prep.downsample(vol(a[t]), 2, "gaussian").data)


def test_downsample_inf_stays_in_its_block():
    a = np.zeros((1, 1, 3))
    a[0, 0, 2] = np.inf  # alone in the last, partial block
    assert prep.downsample(vol(a), 2).data.tolist() == [[[0.0, np.inf]]]


def test_downsample_and_resample_refuse_masks():
    v = vol(np.array([[[1.0, np.nan]]]))
    m = prep.mask_special(v)
    with pytest.raises(ValueError, match="unmask"):
        prep.downsample(m)
    with pytest.raises(ValueError, match="unmask"):
        prep.resample(m, 1.0)
    with pytest.raises(ValueError, match="method"):
        prep.downsample(v, 2, method="lanczos")
    with pytest.raises(ValueError, match="positive integer"):
        prep.downsample(v, 0)


def test_resample_identity_and_shape_math():
    r = np.random.default_rng(4)
    a = r.integers(0, 4000, (5, 6, 7)).astype(np.uint16)
    v = vol(a)
    same = prep.resample(v, v.spacing)
    np.testing.assert_array_equal(same.data, a)
    assert same.spacing == v.spacing and same.origin == v.origin
    iso = prep.resample(v, 0.5)  # z spans 8 -> 17 samples, y unchanged, x spans 6 -> 13
    assert iso.shape == (17, 6, 13) and iso.spacing == (0.5, 0.5, 0.5)
    assert iso.origin == v.origin and iso.dtype == np.uint16
    assert prep.resample(v, (3.0, 0.5, 4.0)).shape == (3, 6, 2)
    one = prep.resample(vol(np.ones((1, 1, 1))), 0.1)
    assert one.shape == (1, 1, 1)


def test_resample_reproduces_linear_functions():
    spacing = (1.5, 0.7, 1.0)
    z, y, x = np.meshgrid(
        *(np.arange(n) * s for n, s in zip((6, 9, 7), spacing, strict=True)), indexing="ij"
    )

    def f(z, y, x):
        return 3.0 + 2.0 * z - 1.25 * y + 0.5 * x + 0.1 * x * y * z  # trilinear in (z, y, x)

    v = Volume(f(z, y, x), spacing=spacing)
    out = prep.resample(v, (0.4, 1.1, 0.3))
    gz, gy, gx = np.meshgrid(
        *(np.arange(n) * s for n, s in zip(out.shape, out.spacing, strict=True)), indexing="ij"
    )
    np.testing.assert_allclose(out.data, f(gz, gy, gx), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("order", [0, 1])
@pytest.mark.parametrize("dtype", [np.float64, np.int16])
def test_resample_matches_naive(order, dtype):
    r = np.random.default_rng(5 + order)
    a = r.normal(0, 100, (4, 5, 3)).astype(dtype)
    old, new = (1.0, 0.8, 2.0), (0.6, 1.3, 0.7)
    out = prep.resample(Volume(a, spacing=old), new, order=order)
    ref = naive.prep_resample(a, old, new, order)
    assert out.shape == ref.shape
    if dtype == np.float64:
        np.testing.assert_allclose(out.data, ref, rtol=1e-12, atol=1e-12)
    else:
        np.testing.assert_array_equal(out.data, np.rint(ref).astype(dtype))


# --- astype ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("rounding", "expected"),
    [
        ("nearest", [-2, 0, 0, 2, 2, 3, -3]),
        ("floor", [-2, -1, 0, 1, 2, 2, -3]),
        ("trunc", [-1, 0, 0, 1, 2, 2, -2]),
    ],
)
def test_astype_rounding_modes(rounding, expected):
    a = np.array([[[-1.5, -0.5, 0.5, 1.5, 2.5, 2.7, -2.7]]])
    out = prep.astype(vol(a), np.int16, rounding=rounding)
    assert out.data.tolist() == [[expected]] and out.dtype == np.int16
    assert out.meta["clipped"] == 0


def test_astype_clips_and_counts():
    a = np.array([[[-3.0, 300.0, 5.4, 255.4, 255.6]]], np.float32)
    out = prep.astype(vol(a), np.uint8)
    assert out.data.tolist() == [[[0, 255, 5, 255, 255]]] and out.meta["clipped"] == 3
    with pytest.raises(ValueError, match="found 3 outside"):
        prep.astype(vol(a), np.uint8, clip=False)
    i = prep.astype(vol(np.array([[[-1, 70000, 5]]], np.int32)), np.uint16)
    assert i.data.tolist() == [[[0, 65535, 5]]] and i.meta["clipped"] == 2
    assert prep.astype(vol(np.array([[[7]]], np.uint8)), np.int64).meta["clipped"] == 0


def test_astype_64_bit_edges_are_exact():
    # 2**63 rounds up as a float64: the largest float64 below it is the clip bound
    a = np.array([[[1e19, -1e19, 9.2e18]]])
    out = prep.astype(vol(a), np.int64)
    assert out.data.tolist() == [[[2**63 - 1024, -(2**63), 9200000000000000000]]]
    assert out.meta["clipped"] == 2
    f = prep.astype(vol(np.array([[[1e300, -np.inf, 2.0]]])), np.float32)
    assert f.data.tolist() == [[[float(np.finfo(np.float32).max), -math.inf, 2.0]]]
    assert f.meta["clipped"] == 1


def test_astype_refuses_unmasked_nan_but_not_masked():
    a = np.array([[[1.2, np.nan, 3.0]]])
    with pytest.raises(FormatError, match="mask_special"):
        prep.astype(vol(a), np.uint8)
    m = prep.astype(prep.mask_special(vol(a)), np.uint8)
    assert m.data.tolist() == [[[1, 1, 3]]] and m.mask.tolist() == [[[False, True, False]]]
    back = prep.unmask_special(prep.astype(m, np.float64))
    assert np.isnan(back.data[0, 0, 1]) and back.mask is None


# --- special values --------------------------------------------------------------------


def _specials(seed, shape=(4, 5, 6), dtype=np.float32):
    r = np.random.default_rng(seed)
    a = r.normal(0, 10, shape).astype(dtype)
    pick = r.random(shape)
    a[pick < 0.1] = np.nan
    a[(pick >= 0.1) & (pick < 0.15)] = np.inf
    a[(pick >= 0.15) & (pick < 0.2)] = -np.inf
    a[(pick >= 0.2) & (pick < 0.25)] = -999.25
    return a


def test_mask_special_round_trip_is_exact():
    a = _specials(8)
    m = prep.mask_special(vol(a), fill_value=-999.25)
    sp = m.meta["special"]
    assert sp["nan"] == np.isnan(a).sum() and sp["posinf"] == (a == np.inf).sum()
    assert sp["neginf"] == (a == -np.inf).sum() and sp["nfill"] == (a == -999.25).sum()
    assert sp["fill"] == -999.25 and sp["kinds"].size == m.mask.sum()
    assert np.isfinite(m.data).all() and m.data.min() > -999.25
    np.testing.assert_array_equal(m.mask, ~np.isfinite(a) | (a == -999.25))
    back = prep.unmask_special(m)
    assert back.mask is None and "special" not in back.meta
    np.testing.assert_array_equal(np.isnan(back.data), np.isnan(a))
    keep = ~np.isnan(a)
    assert back.data[keep].tobytes() == a[keep].tobytes()


def test_single_kind_needs_no_kind_array_and_json_survives():
    a = np.array([[[1.0, np.nan, 2.0, np.nan]]])
    m = prep.mask_special(vol(a))
    assert m.meta["special"]["kinds"] is None and m.data.tolist() == [[[1.0, 1.0, 2.0, 1.0]]]
    mixed = prep.mask_special(vol(np.array([[[np.inf, np.nan, 2.0]]])))
    # what a JSON header gives back: the kind codes as a list
    meta = dict(mixed.meta, special=dict(mixed.meta["special"], kinds=[2, 1]))
    back = prep.unmask_special(mixed.replace(meta=meta))
    assert back.data[0, 0, 0] == np.inf and np.isnan(back.data[0, 0, 1])


def test_integer_fill_value():
    a = np.array([[[-1, 5, -1, 7]]], np.int16)
    m = prep.mask_special(vol(a), fill_value=-1)
    assert m.data.tolist() == [[[5, 5, 5, 7]]] and m.meta["special"]["nfill"] == 2
    np.testing.assert_array_equal(prep.unmask_special(m).data, a)
    assert prep.mask_special(vol(a), fill_value=1e9).mask is None  # out of range: no match
    big = np.array([[[2**62 + 1, 3]]], np.int64)  # not a float64 value: compared as an int
    m = prep.mask_special(vol(big), fill_value=2**62 + 1)
    assert m.mask.tolist() == [[[True, False]]]
    np.testing.assert_array_equal(prep.unmask_special(m).data, big)
    assert prep.mask_special(vol(np.ones((1, 1, 2), np.float32)), fill_value=1e300).mask is None


def test_crop_keeps_special_record_consistent():
    a = _specials(9, shape=(5, 6, 7), dtype=np.float64)
    m = prep.mask_special(vol(a), fill_value=-999.25)
    c = prep.unmask_special(prep.crop(m, "1:4,2:,:5"))
    np.testing.assert_array_equal(c.data, a[1:4, 2:, :5])  # assert_array_equal: NaN == NaN


def test_special_record_errors():
    m = prep.mask_special(vol(np.array([[[np.inf, np.nan, 2.0]]])))
    with pytest.raises(FormatError, match="mix"):
        prep.unmask_special(m.replace(meta={"special": dict(m.meta["special"], kinds=None)}))
    with pytest.raises(FormatError, match="found none"):
        prep.unmask_special(m.replace(meta={}))
    with pytest.raises(ValueError, match="unmask it first"):
        prep.mask_special(m)
    q = prep.quantize(m, 8)
    with pytest.raises(FormatError, match="float voxels"):
        prep.unmask_special(q)


# --- quantize --------------------------------------------------------------------------


def _bound(x, rec):
    """scale/2 plus float rounding: of float64 arithmetic and of the cast to the output type."""
    eps_out = np.finfo(np.dtype(rec["dtype"])).eps
    top = max(abs(rec["offset"]), abs(rec["offset"] + rec["scale"] * (2 ** rec["bits"] - 1)))
    slack = 4 * np.finfo(np.float64).eps * top + eps_out * (np.abs(x) + rec["scale"])
    return rec["scale"] / 2 * (1 + 1e-12) + slack


def _check_quantize(a, bits):
    q = prep.quantize(vol(a), bits)
    rec = q.meta["quantize"]
    assert q.dtype == (np.uint8 if bits <= 8 else np.uint16 if bits <= 16 else np.uint32)
    assert int(q.data.max()) <= 2**bits - 1
    d = prep.dequantize(q)
    assert d.dtype == a.dtype and "quantize" not in d.meta
    back = prep.unmask_special(d)
    fin = np.isfinite(a)
    x = a[fin].astype(np.float64)
    err = np.abs(back.data[fin].astype(np.float64) - x)
    assert (err <= _bound(x, rec)).all()
    # the record is the measured error, of dequantize() and of a float64 reader alike
    err64 = np.abs(q.data[fin] * rec["scale"] + rec["offset"] - x)
    assert rec["max_error"] == max(err.max(initial=0.0), err64.max(initial=0.0))
    # specials come back at the same places, bit for bit apart from NaN payloads
    np.testing.assert_array_equal(np.isnan(back.data), np.isnan(a))
    np.testing.assert_array_equal(back.data[np.isinf(a)], a[np.isinf(a)])
    return rec


@given(
    a=hnp.arrays(
        st.sampled_from([np.float32, np.float64]),
        hnp.array_shapes(min_dims=3, max_dims=3, max_side=5),
        elements={
            "allow_nan": False,
            "allow_infinity": False,
            "min_value": -(2.0**100),
            "max_value": 2.0**100,
        },
    ),
    bits=st.sampled_from([1, 5, 8, 12, 16, 24, 32]),
)
def test_quantize_error_bound(a, bits):
    _check_quantize(a, bits)


@given(
    a=hnp.arrays(
        np.float32,
        hnp.array_shapes(min_dims=3, max_dims=3, max_side=4),
        elements=st.one_of(
            st.floats(-1e6, 1e6, width=32), st.sampled_from([np.nan, np.inf, -np.inf])
        ),
    ),
    bits=st.sampled_from([8, 16]),
)
def test_quantize_keeps_specials(a, bits):
    rec = _check_quantize(a, bits)
    if not np.isfinite(a).any():
        assert rec["scale"] == 0.0 and rec["max_error"] == 0.0


def test_quantize_constant_and_given_range():
    c = prep.quantize(vol(np.full((2, 3, 4), 3.25, np.float32)), 16)
    assert c.meta["quantize"]["scale"] == 0.0 and (c.data == 0).all()
    assert c.meta["quantize"]["max_error"] == 0.0
    np.testing.assert_array_equal(prep.dequantize(c).data, np.full((2, 3, 4), 3.25, np.float32))
    a = np.array([[[-1.0, 0.0, 0.5, 1.0, 3.0]]])
    q = prep.quantize(vol(a), 8, lo=0.0, hi=1.0)
    assert q.data.tolist() == [[[0, 0, 128, 255, 255]]]
    back = prep.dequantize(q).data
    assert q.meta["quantize"]["max_error"] == np.abs(back - a).max() == 2.0


def test_quantize_integers_and_checks():
    a = np.arange(0, 1000, 7, dtype=np.int32).reshape(1, 1, -1)
    q = prep.quantize(vol(a), 8)
    d = prep.dequantize(q)
    assert d.dtype == np.float64 and q.meta["quantize"]["dtype"] == "float64"
    assert np.abs(d.data - a).max() == q.meta["quantize"]["max_error"] <= 994 / 255 / 2 + 1e-9
    with pytest.raises(ValueError, match="bits"):
        prep.quantize(vol(a), 33)
    with pytest.raises(ValueError, match="lo <= hi"):
        prep.quantize(vol(a), 8, lo=5, hi=1)
    with pytest.raises(ValueError, match="quantize"):
        prep.dequantize(vol(a))


def test_quantize_chunks_agree(monkeypatch):
    a = _specials(11, shape=(6, 7, 8), dtype=np.float64)
    whole = prep.quantize(vol(a), 12)
    monkeypatch.setattr(prep, "_CHUNK", 13)
    parts = prep.quantize(vol(a), 12)
    np.testing.assert_array_equal(whole.data, parts.data)
    assert whole.meta["quantize"] == parts.meta["quantize"]
