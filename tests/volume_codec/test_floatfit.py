"""The fitted float predictor (mode 5, tool 3 of the lossless codec): its residuals
against a numpy reference of the sum, bit-exact round trips of special values (NaN with
a payload, -0.0, +-Inf, denormals) with and without the fit, the encoder's choice,
version 6 against 5, corrupt payloads, and the golden stream."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import flip_bits, slow_case, traced_peak
from volume_codec.test_floatpredict import same_bits

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.parallel import one_blas_thread
from volpack.volume_codec import floatfit as ff
from volpack.volume_codec import floatpredict as fp
from volpack.volume_codec import lossless
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


def with_specials(a, at=0):
    """``a`` with NaN (one with a payload), -0.0, +-Inf and the smallest denormals in
    place (at the same flat positions, ``at`` on, whatever the shape)."""
    a = a.copy()
    flat = a.reshape(-1)[at:]
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
    args = (
        s,
        f,
        si,
        sf,
        w64,
        steps,
        *nobox,
        shape,
        np.int64(32),
        np.int64(2),
        True,
        out,
        el,
        rs,
        models,
    )
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


def test_fit_summed_in_slabs_matches_one_sum(monkeypatch):
    """The normal equations summed slab by slab give the weights of one whole-brick sum
    (to float32 rounding, on a well-conditioned noisy field), with and without rows left
    out for non-finite values."""
    a = rough((20, 24, 28), seed=5)
    b = with_specials(a)
    whole = [ff.fit(a), ff.fit(b)]
    monkeypatch.setattr(ff, "FIT_CHUNK_ROWS", 2 * 21 * 25)  # two slices a slab
    slabs = [ff.fit(a), ff.fit(b)]
    for w0, w1 in zip(whole, slabs):
        assert w0 is not None and w1 is not None
        np.testing.assert_allclose(w1, w0, rtol=1e-4, atol=1e-6)
    assert not np.array_equal(whole[0], whole[1])  # the specials' rows were left out


def test_fit_memory_does_not_grow_with_the_brick():
    """A 64x128x128 brick's fit allocates a few slabs of neighbours, not the whole
    matrix (1M rows x 23 float64 = 190 MB, three copies of it before)."""
    a = rough((64, 128, 128), seed=2)
    w, peak = traced_peak(ff.fit, a)
    assert w is not None
    assert peak < a.size * 8 + 40 * 2**20  # the float64 copy + slabs of FIT_CHUNK_ROWS


def test_fit_not_run_where_a_lattice_is_far_shorter(monkeypatch):
    """Integers stored as floats: the lattice codes far shorter than any Lorenzo
    predictor, so the fit (at most a few per cent under Lorenzo) is not run, and the
    payload is the one the encoder keeps when it is run."""
    rng = np.random.default_rng(8)
    a = (np.cumsum(rng.integers(-3, 4, (10, 16, 18)), axis=2) - 40).astype(np.float32)
    codec = LosslessCodec(predict_version=6)
    calls = []
    real = ff.encode_best
    monkeypatch.setattr(ff, "encode_best", lambda *args: calls.append(1) or real(*args))
    kept = codec.encode(a)
    assert calls == [] and describe(kept) == "float-lattice"
    monkeypatch.setattr(lossless, "FIT_MAX_GAIN", 1.0)  # never skipped
    assert codec.encode(a) == kept and calls == [1]
    calls.clear()
    monkeypatch.setattr(lossless, "FIT_MAX_GAIN", 0.25)
    codec.encode(rough((10, 16, 18)))  # full mantissas: no shorter tool, the fit runs
    assert calls == [1]


def test_corrupt_payloads_raise_format_error():
    codec = LosslessCodec()
    a = rough((8, 9, 10))
    good = bytes([MODE_FLOAT, 3]) + ff.encode(a, 2, ff.fit(a))
    assert good[2] == 6  # fitted, Lorenzo 2 on the faces
    bad = [
        good[:2] + bytes([8]) + good[3:],  # predictor byte past 7
        good[: 3 + 4 * ff.NFIT],  # weights but no stream
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


def golden_payloads(stem, want, **options):
    """The payloads of golden file ``stem``, after checking that it decodes to ``want``
    and that the encoder writes it again byte for byte with ``options``."""
    blob = (GOLDEN / f"{stem}.vpk").read_bytes()
    assert same_bits(api.decompress(blob).data, want)
    again = api.compress_array(want, **options)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
        return [p for _, _, p in old]


def test_golden_fit_stream():
    payloads = golden_payloads("lossless-v6-f32-fit", golden_source(), brick=32, predict_version=6)
    assert [describe(p) for p in payloads] == ["float-fit"]
    assert payloads[0][2] >= ff.FITTED  # the fitted variant


# --- the box fit (predictor byte 8 + P, version 10) --------------------------------------


def wide(shape=(10, 40, 48)):
    """The recipe of scripts/make_examples.py's ``f32-wide``, written out again on
    purpose: smooth waves with no noise (a wide fit predicts them better than 23
    neighbours), special values in place."""
    z, y, x = np.indices(shape)
    f = np.sin(x * 0.21 + z * 0.3) * np.cos(y * 0.17) * 10.0 + np.sin(x * 0.05 + y * 0.11) * 30
    return with_specials(f.astype(np.float32), 4000)


def kernel_residuals(a, face, w, box):
    """The residuals the encoder kernel codes."""
    s = to_signed(a).reshape(-1)
    f = a.astype(np.float64).reshape(-1)
    si, sf = fp.scratch(a.dtype)
    el, rs, models = ff._workspace(s.size)
    out = np.empty(8 * s.size + 1024, np.uint8)
    (shape3, wb) = box
    args = (
        s, f, si, sf, w.astype(np.float64), ff._steps(a.shape), wb.astype(np.float64),
        ff._steps(a.shape, ff.box_offsets(*shape3)), np.array(shape3, np.int64),
        np.array(a.shape, np.int64), np.int64(8 * a.itemsize), np.int64(face), True, out,
        el, rs, models,
    )  # fmt: skip
    assert ff._encode_kernel(*args) > 0
    return rs.reshape(a.shape)


@pytest.mark.parametrize("shape3", [(1, 3, 3), (2, 2, 2), (3, 1, 1)])
def test_box_residuals_match_the_naive_reference(shape3):
    from naive import float_fit_residuals

    a = with_specials(rough((5, 18, 20)))
    w, wb = ff.fit(a), ff.fit_box(a, shape3)
    assert w is not None and wb is not None and wb.size == len(ff.box_offsets(*shape3))
    a[3, 10, 11] = np.float32(3e38)  # box sums that overflow: the 23-fit's sums instead
    for face in (1, 2):
        want = float_fit_residuals(a, face, w, (shape3, wb))
        assert np.array_equal(kernel_residuals(a, face, w, (shape3, wb)), want)


def test_box_weights_equal_the_row_matrix_formula():
    """The rows gathered once per pass, the refit gathering only the rows it takes out:
    the same numpy sums on the same numbers as the stacked row matrices, so the same
    weights bit for bit (with special values, which drop rows, and with a trimmed refit
    on the smooth waves)."""
    from naive import float_box_offsets, float_box_weights

    cases = [
        (with_specials(rough((6, 20, 22))), (1, 3, 3)),
        (with_specials(rough((6, 20, 22))), (2, 4, 2)),
        (rough((9, 30, 34), seed=3), (1, 7, 7)),
        (wide(), (1, 7, 7)),
        (wide(), (1, 10, 10)),
    ]
    for a, shape3 in cases:
        with one_blas_thread():  # as the encoder runs them (the same numpy calls)
            want = float_box_weights(a, shape3, max_rows=ff.BOX_FIT_ROWS, trim=ff.BOX_TRIM)
            got = ff.fit_box(a, shape3)
        assert want is not None and got.dtype == np.float32
        assert np.array_equal(got.view(np.uint32), want.view(np.uint32))
    assert ff.box_offsets(3, 2, 4) == float_box_offsets(3, 2, 4)
    # more rows than a fit takes: every 8th slice, as the formula samples them
    a = rough((12, 40, 44), seed=5)
    import unittest.mock

    with one_blas_thread(), unittest.mock.patch.object(ff, "BOX_FIT_ROWS", 2000):
        want = float_box_weights(a, (1, 3, 3), max_rows=2000, trim=ff.BOX_TRIM)
        got = ff.fit_box(a, (1, 3, 3))
    assert np.array_equal(got.view(np.uint32), want.view(np.uint32))


# slow set: about 6-10 CPU s of its own, in subprocesses or repeated encodes (session 34)
@pytest.mark.slow
def test_files_are_the_same_bytes_on_any_number_of_blas_threads():
    """OpenBLAS splits the normal equations' sums by its thread count (the box weights of
    these waves differ between one and two threads): compress runs BLAS on one thread
    whatever the caller set, with one worker or two, and gives the setting back."""
    from threadpoolctl import ThreadpoolController, threadpool_limits

    a = wide((24, 72, 72))
    got = []
    for n in (1, 2, 4):
        with threadpool_limits(limits=n, user_api="blas"):
            with one_blas_thread():
                w = ff.fit_box(a, (1, 10, 10))
            got.append((w.tobytes(), api.compress_array(a, effort="max", workers=n % 3)))
            blas = [i["num_threads"] for i in ThreadpoolController().info() if i["user_api"] == "blas"]
            assert all(t == n for t in blas)  # the limit is lifted after the fit
    # (unguarded, on two OpenBLAS threads, this fit's weights differ here: measured on
    # a 2-core machine, not asserted, as a 1-core machine has no second thread)
    assert got[1] == got[0] and got[2] == got[0]


def test_fit_rows_are_the_neighbours_windows():
    a = rough((5, 9, 11)).astype(np.float64)
    offs = ff.box_offsets(1, 2, 3)
    idx = np.array([(1 * 9 + 2) * 11 + 3, (4 * 9 + 6) * 11 + 7], np.int64)
    x, y = ff.fit_rows(a.reshape(-1), ff._steps(a.shape, offs), idx)
    for r, (z, yy, xx) in enumerate([(1, 2, 3), (4, 6, 7)]):
        assert y[r] == a[z, yy, xx]
        assert list(x[r]) == [a[z - dz, yy - dy, xx - dx] for dz, dy, dx in offs]


def test_box_offsets_are_causal_and_w_last():
    for shape3 in [(1, 1, 1), (1, 7, 7), (3, 15, 15)]:
        offs = ff.box_offsets(*shape3)
        rz, ry, rx = shape3
        assert offs[-1] == (0, 0, 1) and len(set(offs)) == len(offs)
        assert len(offs) == rz * (2 * ry + 1) * (2 * rx + 1) + ry * (2 * rx + 1) + rx
        assert all(dz > 0 or dy > 0 or (dy == 0 and dx > 0) for dz, dy, dx in offs)


@pytest.mark.parametrize("dtype", DTYPES)
def test_box_round_trips_are_bit_exact(dtype):
    a = with_specials(rough((6, 20, 22), dtype=dtype))
    w = ff.fit(a)
    for shape3 in [(1, 3, 3), (2, 4, 2)]:
        wb = ff.fit_box(a, shape3)
        assert wb is not None
        for face in fp.PREDICTORS:
            data = ff.encode(a, face, w, (shape3, wb))
            assert data[0] == ff.BOXED + face and tuple(data[1:4]) == shape3
            assert same_bits(ff.decode(data, a.shape, dtype), a)
    # the largest box the decoder takes, in a brick too small for any voxel to use it,
    # and weights that overflow to Inf everywhere: every voxel falls back
    big = (3, 15, 15)
    k = len(ff.box_offsets(*big))
    for wb in (np.full(k, 1.0 / k, np.float32), np.full(k, 3e38, np.float32)):
        assert same_bits(ff.decode(ff.encode(a, 2, w, (big, wb)), a.shape, dtype), a)
    with pytest.raises(ValueError):
        ff.encode(a, 2, None, ((1, 1, 1), np.zeros(13, np.float32)))


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_version_10_keeps_the_box_where_shorter():
    a = wide()
    lor = fp.encode_best_lorenzo(a)
    plain = ff.encode_best(a, lor[0])
    boxed = ff.encode_best(a, lor[0], ff.BOX_SHAPES)
    assert boxed[0] >= ff.BOXED and len(boxed) < 0.97 * len(plain)
    assert plain == ff.encode_best(a, lor[0], ())  # versions before 10: no box
    b10 = api.compress_array(a, brick=64, predict_version=10)
    assert b10 == api.compress_array(a, brick=64, effort="max")
    assert b10 == api.compress_array(a, brick=64, effort="max", workers=2)
    assert same_bits(api.decompress_array(b10), a)
    with Reader(b10) as r:
        assert [describe(p) for _, _, p in r] == ["float-fit+box"]
    with Reader(api.compress_array(a, brick=64, predict_version=9)) as r:
        assert [describe(p) for _, _, p in r] == ["float-fit"]
    # a noisy field: the box's hundreds of weights do not pay, the 23 stay
    n = rough((8, 24, 28))
    assert ff.encode_best(n, 2, ff.BOX_SHAPES) == ff.encode_best(n, 2)


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_wider_boxes_not_tried_after_one_that_does_not_pay(monkeypatch):
    fitted = []
    real = ff.fit_box
    monkeypatch.setattr(ff, "fit_box", lambda b, shape: fitted.append(shape) or real(b, shape))
    ff.encode_best(rough((16, 48, 56)), 2, ff.BOX_SHAPES)  # noise: the first box loses
    assert fitted == [ff.BOX_SHAPES[0]]
    fitted.clear()
    ff.encode_best(wide(), 2, ff.BOX_SHAPES)  # the box pays: every shape is tried
    assert fitted == list(ff.BOX_SHAPES)


def test_corrupt_box_payloads_raise_format_error():
    from volpack.volume_codec.lossless import FIT_BOXED

    assert FIT_BOXED == ff.BOXED
    codec = LosslessCodec()
    a = rough((6, 12, 14))
    shape3 = (1, 2, 3)
    good = bytes([MODE_FLOAT, 3]) + ff.encode(a, 2, ff.fit(a), (shape3, ff.fit_box(a, shape3)))
    assert good[2] == ff.BOXED + 2
    head = 3 + 3 + 4 * (ff.NFIT + len(ff.box_offsets(*shape3)))
    bad = [
        good[:2] + bytes([12]) + good[3:],  # predictor byte past 11
        good[:3] + bytes([0]) + good[4:],  # a half-width of 0
        good[:3] + bytes([4]) + good[4:],  # past BOX_MAX
        good[:5] + bytes([16]) + good[6:],
        good[:5],  # a shape cut short
        good[:head],  # weights but no stream
        good[: head - 5],  # weights cut short
        good[:-3],  # a stream cut short
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    flip_bits(codec, good, a, np.random.default_rng(6), 40)


def test_golden_box_stream():
    # session 21's file was fitted with OpenBLAS on two threads (its weights differ in
    # their last bits from a one-thread fit's, as every fit now runs): it still decodes
    old = (GOLDEN / "lossless-v10-f32-fit-box-s21.vpk").read_bytes()
    assert same_bits(api.decompress(old).data, wide())
    payloads = golden_payloads("lossless-v10-f32-fit-box", wide(), brick=64, predict_version=10)
    assert [describe(p) for p in payloads] == ["float-fit+box"]
    assert payloads[0][3:6] == bytes(ff.BOX_SHAPES[0])
