"""The fitted float predictor (mode 5, tool 3 of the lossless codec): its residuals
against a numpy reference of the sum, bit-exact round trips of special values (NaN with
a payload, -0.0, +-Inf, denormals) with and without the fit, the encoder's choice,
version 6 against 5, corrupt payloads, and the golden stream."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import flip_bits, slow_case
from volume_codec.test_floatpredict import same_bits

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import floatfit as ff
from volpack.volume_codec import floatpredict as fp
from volpack.volume_codec.floatbits import to_signed
from volpack.volume_codec.lossless import MODE_FLOAT, LosslessCodec, describe

# float64 compiles kernel variants of its own: its cases run in the slow set
DTYPES = [np.float32, slow_case(np.float64)]


def rough(shape=(12, 13, 14), dtype=np.float32, seed=1):
    """A smooth field under correlated noise (the full mantissas of a turbulent field):
    a fit over many neighbours averages the noise a Lorenzo predictor passes on."""
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    f = np.sin(x * 0.3 + z * 0.2) * np.cos(y * 0.25) * 10.0
    noise = rng.normal(0, 0.05, shape)
    f += noise + 0.5 * np.roll(noise, 1, axis=2) + 0.5 * np.roll(noise, 1, axis=1)
    return f.astype(dtype)


def with_specials(a):
    """``a`` with NaN (one with a payload), -0.0, +-Inf and the smallest denormals in
    place (at the same flat positions whatever the shape)."""
    a = a.copy()
    flat = a.reshape(-1)
    payload = np.array([0x7FC01234], np.uint32).view(np.float32)[0]
    flat[1007:1009] = (np.nan, payload if a.itemsize == 4 else -np.nan)
    flat[1108:1111] = (-0.0, np.inf, -np.inf)
    tiny = np.finfo(a.dtype).smallest_subnormal
    flat[1313], flat[1567] = tiny, -tiny
    return a


def test_residuals_match_a_numpy_reference():
    a = rough()
    w = ff.fit(a)
    assert w is not None and w.dtype == np.float32
    s = to_signed(a).reshape(-1)
    f = a.astype(np.float64).reshape(-1)
    si, sf = fp.scratch(a.dtype)
    el, rs, models = ff._workspace(s.size)
    out = np.empty(8 * s.size + 1024, np.uint8)
    w64, steps = w.astype(np.float64), ff._steps(a.shape)
    shape = np.array(a.shape, dtype=np.int64)
    nobox = (np.zeros(1), steps[:1], np.zeros(3, np.int64))
    args = (s, f, si, sf, w64, steps, *nobox, shape, np.int64(32), np.int64(2), True, out, el, rs, models)
    assert ff._encode_kernel(*args) > 0
    nz, ny, nx = a.shape
    v = a.astype(np.float64)
    parts = [np.zeros((nz - 2, ny - 3, nx - 3)) for _ in range(4)]
    for k, (dz, dy, dx) in enumerate(ff.FIT_OFFSETS[:-1]):
        sl = v[2 - dz : nz - dz, 2 - dy : ny - 1 - dy, 2 - dx : nx - 1 - dx]
        parts[k % 4 if k < 20 else k - 20] += w64[k] * sl
    q = ((parts[0] + parts[1]) + (parts[2] + parts[3])) + w64[-1] * v[2:, 2 : ny - 1, 1 : nx - 2]
    want = to_signed(a)[2:, 2 : ny - 1, 2 : nx - 1] - to_signed(q.astype(np.float32))
    assert np.array_equal(rs.reshape(a.shape)[2:, 2 : ny - 1, 2 : nx - 1], want)
    # the faces take the Lorenzo predictor named (the first voxel: nothing to predict from)
    assert rs[0] == s[0]


@pytest.mark.parametrize("dtype", DTYPES)
def test_round_trips_are_bit_exact(dtype):
    a = with_specials(rough(dtype=dtype))
    w = ff.fit(a)  # the rows holding a special value are left out of the fit
    assert w is not None
    for face in fp.PREDICTORS:
        for weights in (None, w):
            got = ff.decode(ff.encode(a, face, weights), a.shape, dtype)
            assert same_bits(got, a)
    thin = with_specials(rough((9, 3, 60), dtype))  # no interior: faces only
    assert ff.fit(thin) is None and ff.encode_best(thin, 3) is None
    assert same_bits(ff.decode(ff.encode(thin, 3), thin.shape, dtype), thin)


def test_fit_codes_shorter_than_lorenzo_and_the_codec_keeps_it():
    a = rough((16, 20, 24))
    lor = fp.encode_best_lorenzo(a)
    fitted = ff.encode(a, lor[0], ff.fit(a))
    assert len(fitted) < 0.97 * len(lor)
    assert ff.encode_best(a, lor[0]) == fitted
    blob = api.compress_array(a)
    assert same_bits(api.decompress_array(blob), a)
    with Reader(blob) as r:
        assert [describe(p) for _, _, p in r] == ["float-fit"]
        assert r.header["codec"]["predict_version"] == 8
    older = api.compress_array(a, predict_version=5)
    with Reader(older) as r:
        assert "float-fit" not in {describe(p) for _, _, p in r}


def test_corrupt_payloads_raise_format_error():
    codec = LosslessCodec()
    a = rough((8, 9, 10))
    good = bytes([MODE_FLOAT, 3]) + ff.encode(a, 2, ff.fit(a))
    assert good[2] == 6  # fitted, Lorenzo 2 on the faces
    bad = [
        good[:2] + bytes([8]) + good[3:],  # predictor byte past 7
        good[:3 + 4 * ff.NFIT],  # weights but no stream
        good[:2] + bytes([2]),  # a predictor byte alone
        good[:2],  # no predictor byte
        good[:-3],  # a stream cut short
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    with pytest.raises(FormatError):  # a float16 brick has no fit tool
        codec.decode(good, a.shape, np.float16)
    flip_bits(codec, good, a, np.random.default_rng(5), 40)


# --- golden stream -----------------------------------------------------------------------

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"


def golden_source():
    """The recipe of scripts/make_examples.py's ``f32-rough``, written out again on
    purpose: a noisy field with special values in place."""
    return with_specials(rough((20, 24, 28), np.float32, seed=7))


def test_golden_fit_stream():
    blob = (GOLDEN / "lossless-v6-f32-fit.vpk").read_bytes()
    want = golden_source()
    assert same_bits(api.decompress(blob).data, want)
    again = api.compress_array(want, brick=32, predict_version=6)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
        payloads = [p for _, _, p in old]
    assert [describe(p) for p in payloads] == ["float-fit"]
    assert payloads[0][2] >= ff.FITTED  # the fitted variant
