"""The float blend tool (mode 5, tool 2 of the lossless codec): residuals, copy and fill
marks against the naive reference, bit-exact round trips of special values with and
without copies and a fill value (NaN with a payload, -0.0), the encoder's choice of
offsets and fill, version 4 against 3, and corrupt payloads."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import naive
import numpy as np
import pytest
from conftest import flip_bits, slow_case
from volume_codec.test_floatpredict import field, same_bits, specials

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import floatmix as fm
from volpack.volume_codec.floatbits import to_signed
from volpack.volume_codec.lossless import MODE_FLOAT, LosslessCodec, describe

# float64 compiles kernel variants of its own: its cases run in the slow set
DTYPES = [np.float32, slow_case(np.float64)]


def periodic(shape=(10, 12, 14), period=(0, 0, 9), dtype=np.float32, seed=3):
    """A random walk along x repeated with ``period`` along each axis it names (a unit
    cell and copies of its start past it)."""
    rng = np.random.default_rng(seed)
    a = (np.cumsum(rng.normal(0, 1, shape), axis=2) + 100).astype(dtype)
    for axis, p in enumerate(period):
        if p:
            idx = [slice(None)] * 3
            src = list(idx)
            idx[axis] = slice(p, None)
            src[axis] = slice(0, shape[axis] - p)
            a[tuple(idx)] = a[tuple(src)]
    return a


def masked(dtype=np.float32, fill=0.0, shape=(8, 9, 10)):
    """A field over a blob, ``fill`` elsewhere, and special values inside the blob."""
    a = field(shape, dtype)
    z, y, x = np.indices(shape)
    out = ((z - 4) ** 2 + (y - 4) ** 2 + (x - 5) ** 2) > 12
    a[out] = fill
    a[4, 4, 5], a[4, 4, 6], a[3, 4, 5] = -0.0, np.inf, np.finfo(dtype).smallest_subnormal
    return a


def kernel_marks(a, nset, offsets, fill):
    """``(residuals, copy marks, fill marks)`` the encoder kernel leaves behind."""
    s = to_signed(a).reshape(-1)
    work = fm._workspace(s.size)
    si, sf = fm.scratch(a.dtype)
    fv = np.zeros(2, np.int64)
    if fill is not None:
        fv[:] = to_signed(np.array([fill], a.dtype))[0], 1
    out = np.empty(s.size * 40 + 1024, np.uint8)
    n = fm._encode_kernel(
        s,
        a.astype(np.float64).reshape(-1),
        si,
        sf,
        np.array(a.shape, np.int64),
        np.int64(8 * a.itemsize),
        np.int64(nset),
        np.array(offsets, np.int64).reshape(-1, 3),
        fv,
        out,
        *work,
    )
    assert n > 0
    el, rs, cp, fl = work[:4]
    return rs.reshape(a.shape), cp.reshape(a.shape), fl.reshape(a.shape).astype(bool)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("case", ["specials", "masked", "nan-fill", "periodic", "subset"], ids=str)
def test_blend_matches_naive(dtype, case):
    nset, offsets, fill = fm.ALL_PREDICTORS, (), None
    if case == "specials":
        a = specials(dtype, (5, 6, 7))
    elif case == "masked":
        a, fill = masked(dtype), 0.0
    elif case == "nan-fill":
        a, fill = masked(dtype, np.nan), np.nan
    elif case == "periodic":
        a, offsets = periodic((6, 7, 11), (4, 0, 8), dtype), [(4, 0, 0), (0, 0, 8)]
    else:
        a, nset = specials(dtype, (5, 6, 7)), 0b1010011
    got = kernel_marks(a, nset, offsets, fill)
    want = naive.float_blend_residuals(a, nset, offsets, fill)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 9), (1, 7, 1), (4, 1, 1), (3, 5, 6), (9, 10, 11)]
)
def test_roundtrip_every_shape_with_specials(dtype, shape):
    a = specials(dtype, (9, 10, 11))[: shape[0], : shape[1], : shape[2]].copy()
    for fill in (None, np.nan, -0.0):
        offs = [o for o in [(1, 0, 0), (0, 0, 2)] if all(d < n for d, n in zip(o, shape))]
        data = fm.encode(a, offsets=offs, fill=fill)
        assert same_bits(fm.decode(data, a.shape, a.dtype), a)


def test_nan_payload_fill_is_kept_bit_for_bit():
    a = masked(np.float32, np.nan)
    bits = a.view(np.uint32)
    payload = np.uint32(0x7FC00ABC)
    bits[np.isnan(a)] = payload
    bits[0, 0, 0] = 0xFFC00001  # another NaN: not the fill, coded as a value
    fill = np.array([payload]).view(np.float32)[0]
    data = fm.encode(a, fill=fill)
    assert same_bits(fm.decode(data, a.shape, a.dtype), a)
    assert fm.fill_value(a).view(np.uint32) == payload


def test_copy_offsets_find_the_periods():
    a = periodic((12, 20, 30), (8, 15, 21))
    assert sorted(fm.copy_offsets(a)) == [(0, 0, 21), (0, 15, 0), (8, 0, 0)]
    assert fm.copy_offsets(field((8, 9, 10))) == []
    flat = np.zeros((8, 9, 10), np.float32)
    assert fm.copy_offsets(flat) == []  # single steps are the predictor's


def test_copies_and_fill_pay():
    a = periodic((16, 24, 40), (0, 0, 30))
    plain = fm.encode(a)
    copied = fm.encode(a, offsets=fm.copy_offsets(a))
    assert len(copied) < 0.85 * len(plain)  # a quarter of the voxels repeat
    b = masked(np.float32, 0.0, (16, 16, 16))
    assert len(fm.encode(b, fill=0.0)) < 0.7 * len(fm.encode(b))


def test_blend_beats_one_lorenzo_predictor_on_a_field_that_changes():
    """Smooth along x in one half, along z in the other: no one predictor fits both."""
    from volpack.volume_codec import floatpredict as fp

    rng = np.random.default_rng(4)
    a = np.cumsum(rng.normal(0, 1, (16, 16, 32)), axis=2)
    a[:, :, 16:] = np.cumsum(rng.normal(0, 1, (16, 16, 16)), axis=0)
    a = (a + 1000).astype(np.float32)
    best = min(len(fp.encode_lorenzo(a, p)) for p in fp.PREDICTORS)
    assert len(fm.encode(a)) < 0.98 * best


@pytest.mark.slow  # the float decoder's kernels, shared by three slow tests only (kernel_use36.md)
def test_codec_picks_the_blend_for_periodic_and_masked_bricks():
    a = periodic((16, 24, 40), (0, 0, 30))
    b = masked(np.float32, 0.0, (16, 16, 16))
    for v in (a, b):
        blob = api.compress_array(v)
        assert same_bits(api.decompress_array(blob), v)
        with Reader(blob) as r:
            assert Counter(describe(p) for _, _, p in r) == {"float-blend": 1}
            assert r.header["codec"]["predict_version"] == 8
        older = api.compress_array(v, predict_version=3)
        assert same_bits(api.decompress_array(older), v)
        with Reader(older) as r:
            assert "float-blend" not in {describe(p) for _, _, p in r}
        assert len(blob) < len(older)


def test_float16_takes_no_blend():
    a = field((8, 8, 8), np.float16)
    assert describe(LosslessCodec().encode(a)) != "float-blend"
    with pytest.raises(FormatError):
        fm.decode(fm.encode(a.astype(np.float32)), a.shape, np.float16)


def test_corrupt_blend_payloads_raise_format_error():
    codec = LosslessCodec()
    a = periodic((6, 7, 11), (4, 0, 8))
    data = fm.encode(a, offsets=[(4, 0, 0), (0, 0, 8)], fill=a[1, 1, 1])
    good = bytes([MODE_FLOAT, 2]) + data
    assert same_bits(codec.decode(good, a.shape, a.dtype), a)
    head = good[:2]
    bad = [
        head,  # no set byte
        head + bytes([0, 0]) + data[2:],  # empty predictor set
        head + bytes([128, 0]) + data[2:],  # set past the seven predictors
        head + bytes([127, 8]) + data[2:],  # unknown bit in the copies byte
        head + bytes([127, 1]) + bytes([0, 0, 0]) + data[2:],  # an offset of zero
        head + bytes([127, 1]) + bytes([6, 0, 0]) + data[2:],  # past the brick's z extent
        head + bytes([127, 1, 0x80]),  # offset cut inside a number
        head + bytes([127, 4, 0, 0]),  # fill value cut short
        head + bytes([127, 0]),  # no stream
        good[: len(good) // 2],  # cut short
        good + b"\x00\x00",  # does not end where it says
        bytes([MODE_FLOAT, 3]) + data,  # unknown tool
    ]
    for d in bad:
        with pytest.raises(FormatError):
            codec.decode(d, a.shape, a.dtype)


@pytest.mark.parametrize("dtype", [np.float32, slow_case(np.float64)])
def test_bit_flips_raise_or_decode(dtype):
    # float64: the blend decoder's float64 signature (11 CPU s to compile), slow set only
    codec = LosslessCodec()
    rng = np.random.default_rng(6)
    if dtype == np.float32:
        a = masked(np.float32, np.nan)
    else:
        a = periodic((6, 7, 11), (4, 0, 8), dtype)
    good = bytes([MODE_FLOAT, 2]) + fm.encode(a, offsets=fm.copy_offsets(a), fill=fm.fill_value(a))
    flip_bits(codec, good, a, rng, 40)


# --- golden streams ----------------------------------------------------------------------

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"
# The recipes of scripts/make_examples.py, written out again on purpose.
# f64: the blend decoder's float64 signature, compiled for it alone, so in the slow set
GOLDEN_CASES = [
    "lossless-v4-f32-periodic", "lossless-v4-f32-masked", slow_case("lossless-v4-f64-masked")
]


def golden_source(stem):
    from volpack.demo import load_demo_volume

    z, y, x = np.indices((20, 24, 28))
    if stem.endswith("periodic"):
        cut = load_demo_volume().data[30:50, 40:64, 40:68]
        f = (cut * 1.37 - 40.0 + z * 0.011 + y * y * 0.0007 - x * 0.05).astype(np.float32)
        f[:, :, 20:] = f[:, :, :8]
        f[14:] = f[:6]
        f[1, 2, 3:5] = (np.nan, -0.0)
        return f
    f64 = "f64" in stem
    f = np.sin(x * 0.21 + z * 0.05) * np.cos(y * 0.17) * 80.0 + z * 0.3
    f = f.astype(np.float64 if f64 else np.float32)
    f[(z - 10) ** 2 + (y - 12) ** 2 + (x - 14) ** 2 > 80] = np.nan if f64 else 0.0
    f[10, 12, 14:17] = (-0.0, np.inf, 5e-324 if f64 else 1e-42)
    return f


@pytest.mark.parametrize("stem", GOLDEN_CASES)
def test_golden_blend_stream(stem):
    blob = (GOLDEN / f"{stem}.vpk").read_bytes()
    want = golden_source(stem)
    assert same_bits(api.decompress(blob).data, want)
    again = api.compress_array(want, brick=32, predict_version=4)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
        payloads = [p for _, _, p in old]
    assert [describe(p) for p in payloads] == ["float-blend"]
    kinds = payloads[0][3]  # copies (periodic: x and z, first) and fill (masked)
    if stem.endswith("periodic"):
        assert kinds & 3 >= 2 and bytes(payloads[0][4:10]) == bytes([0, 0, 20, 14, 0, 0])
    else:
        assert kinds == 4
