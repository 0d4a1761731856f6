"""The reversible 3-D integer wavelet transform: exactness, reference, growth bound."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import naive
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from volpack.errors import FormatError
from volpack.wavelet import dwt3

WAVELETS = ("53", "97m", "haar", "26")


def _full(shape):
    return dwt3.levels_for_shape(shape, None)


def _round_trip(x, levels, wavelet):
    c = dwt3.forward(x, levels, wavelet)
    assert c.dtype == x.dtype and c.shape == x.shape
    y = dwt3.inverse(c, levels, wavelet)
    np.testing.assert_array_equal(y, x)
    return c


# --- levels and subbands ---


@pytest.mark.parametrize(
    ("shape", "cap", "expected"),
    [
        ((1, 1, 1), None, (0, 0, 0)),
        ((1, 7, 2), None, (0, 3, 1)),
        ((2, 3, 4), None, (1, 2, 2)),
        ((64, 65, 5), None, (6, 7, 3)),
        ((64, 64, 64), 3, (3, 3, 3)),
        ((64, 1, 2), 0, (0, 0, 0)),
        ((0, 5, 1), None, (0, 3, 0)),
    ],
)
def test_levels_for_shape(shape, cap, expected):
    assert dwt3.levels_for_shape(shape, cap) == expected


def test_levels_for_shape_rejects_bad_input():
    with pytest.raises(FormatError):
        dwt3.levels_for_shape((4, 4), None)
    with pytest.raises(FormatError):
        dwt3.levels_for_shape((4, 4, 4), -1)


@pytest.mark.parametrize("shape", [(1, 1, 1), (1, 7, 2), (17, 9, 33), (8, 8, 8), (5, 1, 12)])
@pytest.mark.parametrize("cap", [None, 1, 2])
def test_subbands_tile_the_array(shape, cap):
    levels = dwt3.levels_for_shape(shape, cap)
    bands = dwt3.subbands(shape, levels)
    count = np.zeros(shape, dtype=int)
    for b in bands:
        count[b.slices] += 1
    assert (count == 1).all()
    top, bits = bands[0].level, bands[0].bits
    assert top == max(levels) and bits == (0, 0, 0)
    for level, bits, _, _ in bands[1:]:
        assert any(bits)
        assert all(b == 0 or levels[a] > level for a, b in enumerate(bits))
    assert [b[0] for b in bands[1:]] == sorted((b[0] for b in bands[1:]), reverse=True)


# --- exactness ---

SHAPES = [(1, 1, 1), (1, 7, 2), (17, 9, 33), (2, 2, 2), (3, 3, 3), (1, 1, 20), (20, 1, 1)]
SHAPES += [(n, (n * 7) % 20 + 1, (n * 13) % 20 + 1) for n in range(1, 21)]


@pytest.mark.parametrize("wavelet", WAVELETS)
def test_round_trip_many_shapes(wavelet, rng):
    for shape in SHAPES:
        for dtype in (np.int32, np.int64):
            x = rng.integers(-5000, 5000, shape).astype(dtype)
            _round_trip(x, _full(shape), wavelet)
        # partial and unequal depths
        levels = tuple(min(v, i) for i, v in enumerate(_full(shape)))
        _round_trip(rng.integers(0, 256, shape).astype(np.int32), levels, wavelet)


@pytest.mark.parametrize("wavelet", WAVELETS)
def test_forward_matches_naive(wavelet, rng):
    for shape in [(1, 1, 1), (1, 7, 2), (2, 3, 5), (5, 4, 3), (6, 7, 9), (9, 2, 11)]:
        x = rng.integers(-300, 300, shape)
        for levels in (_full(shape), tuple(min(v, 1) for v in _full(shape))):
            expected = naive.wavelet_forward(x, levels, wavelet)
            got = dwt3.forward(x.astype(np.int64), levels, wavelet)
            np.testing.assert_array_equal(got, expected)


@given(
    shape=st.tuples(*(st.integers(1, 12),) * 3),
    wavelet=st.sampled_from(WAVELETS),
    seed=st.integers(0, 2**32 - 1),
    cap=st.one_of(st.none(), st.integers(0, 4)),
)
def test_round_trip_property(shape, wavelet, seed, cap):
    r = np.random.default_rng(seed)
    x = r.integers(-32768, 32768, shape)
    levels = dwt3.levels_for_shape(shape, cap)
    assert dwt3.work_dtype(-32768, 32767, levels, wavelet) == np.int32
    c32 = _round_trip(x.astype(np.int32), levels, wavelet)
    c64 = _round_trip(x.astype(np.int64), levels, wavelet)
    np.testing.assert_array_equal(c32, c64)


# --- known values ---


@pytest.mark.parametrize("wavelet", WAVELETS)
def test_constant_has_zero_details(wavelet):
    shape = (9, 10, 11)
    levels = _full(shape)
    c = dwt3.forward(np.full(shape, -77, dtype=np.int32), levels, wavelet)
    assert c[0, 0, 0] == -77
    c[0, 0, 0] = 0
    assert not c.any()


def test_53_ramp_has_zero_interior_details():
    nx = 16
    x = np.broadcast_to(np.arange(nx, dtype=np.int32) * 3 - 20, (4, 6, nx)).copy()
    c = dwt3.forward(x, (1, 1, 1), "53")
    # constant along z and y: no z or y detail at all
    assert not c[2:].any() and not c[:, 3:].any()
    high = c[:2, :3, nx // 2 :]
    assert not high[..., :-1].any()  # the last detail sees the mirrored edge
    # interior low-pass samples are the even samples (the last one sees the edge detail)
    np.testing.assert_array_equal(c[:2, :3, : nx // 2 - 1], x[:2, :3, : nx - 2 : 2])


# --- coefficient growth ---


def _patterns(lo, hi, shape):
    z, y, x = np.indices(shape)
    check = np.where((z + y + x) % 2 == 0, lo, hi)
    yield np.full(shape, lo, dtype=np.int64)
    yield np.full(shape, hi, dtype=np.int64)
    yield check.astype(np.int64)
    yield (lo + hi - check).astype(np.int64)


@pytest.mark.parametrize("wavelet", WAVELETS)
@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint16, np.int32])
def test_extremes_stay_within_bound(wavelet, dtype):
    info = np.iinfo(dtype)
    lo, hi = int(info.min), int(info.max)
    for shape in [(17, 9, 33), (16, 16, 16), (3, 2, 5)]:
        levels = _full(shape)
        bmin, bmax = dwt3.coefficient_bound(lo, hi, levels, wavelet)
        wd = dwt3.work_dtype(lo, hi, levels, wavelet)
        assert wd == (np.int64 if dtype == np.int32 else np.int32)
        for x in _patterns(lo, hi, shape):
            # every intermediate level state, computed in int64
            for k in range(max(levels) + 1):
                part = tuple(min(v, k) for v in levels)
                c = _round_trip(x, part, wavelet)
                assert bmin <= c.min() and c.max() <= bmax
            if wd == np.int32:
                np.testing.assert_array_equal(_round_trip(x.astype(np.int32), levels, wavelet), c)


@pytest.mark.parametrize("wavelet", WAVELETS)
def test_intermediate_values_within_bound(wavelet):
    lo, hi = 0, 65535
    shape = (5, 6, 7)
    levels = _full(shape)
    bmin, bmax = dwt3.coefficient_bound(lo, hi, levels, wavelet)
    for x in _patterns(lo, hi, shape):
        seen = []
        naive.wavelet_forward(x, levels, wavelet, seen)
        assert bmin <= min(seen) and max(seen) <= bmax


def test_work_dtype_choices():
    for wavelet in WAVELETS:
        for lo, hi in [(0, 255), (-32768, 32767), (0, 65535)]:
            assert dwt3.work_dtype(lo, hi, (8, 8, 8), wavelet) == np.int32
        assert dwt3.work_dtype(-128, 127, (12, 12, 12), wavelet) == np.int32
        assert dwt3.work_dtype(-(2**31), 2**31 - 1, (1, 0, 0), wavelet) == np.int64
        assert dwt3.work_dtype(0, 2**32 - 1, (8, 8, 8), wavelet) == np.int64
    for wavelet in ("haar", "26"):  # their low-pass never grows
        assert dwt3.work_dtype(0, 65535, (16, 16, 16), wavelet) == np.int32
    with pytest.raises(FormatError):
        dwt3.work_dtype(0, 2**32 - 1, (16, 16, 16), "97m")


def test_bad_arguments():
    x = np.zeros((4, 4, 4), dtype=np.int32)
    with pytest.raises(FormatError):
        dwt3.forward(x, (3, 0, 0), "53")
    with pytest.raises(FormatError):
        dwt3.forward(x.astype(np.int16), (1, 1, 1), "53")
    with pytest.raises(FormatError):
        dwt3.forward(x, (1, 1, 1), "db4")
    with pytest.raises(FormatError):
        dwt3.inverse(x[0], (1, 1), "53")


def test_kernels_run_as_plain_python(tmp_path):
    code = textwrap.dedent(
        """
        import numpy as np
        import naive
        from volpack.wavelet import dwt3
        r = np.random.default_rng(3)
        for w in dwt3.WAVELETS:
            for shape in [(1, 3, 2), (3, 2, 5)]:
                x = r.integers(-99, 99, shape)
                lv = dwt3.levels_for_shape(shape, None)
                for dt in (np.int32, np.int64):
                    c = dwt3.forward(x.astype(dt), lv, w)
                    assert (c == naive.wavelet_forward(x, lv, w)).all(), (w, shape)
                    assert (dwt3.inverse(c, lv, w) == x).all(), (w, shape)
        print("ok")
        """
    )
    tests = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(
        os.environ,
        NUMBA_DISABLE_JIT="1",
        PYTHONPATH=os.pathsep.join([tests, os.path.dirname(tests)]),
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


@pytest.mark.parametrize("shape,levels", [((9, 13, 20), (0, 3, 4)), ((6, 7, 1), (2, 2, 0))])
def test_rows_scan_is_the_line_scan_with_each_band_row_as_a_subtree(shape, levels):
    from volpack.entropy import CODERS
    from volpack.wavelet import sigmap

    line, rows = sigmap.scan(shape, levels, "line"), sigmap.scan(shape, levels, "rows")
    for a, b in zip(line, rows):
        if a is not line.end:
            np.testing.assert_array_equal(a, b)
    flat = np.arange(int(np.prod(shape)))
    z, y, x = np.unravel_index(line.perm, shape)
    for band in dwt3.subbands(shape, levels):  # a row start points past its row
        inside = np.all(
            [(s <= c) & (c < s + n) for s, n, c in zip(band.start, band.size, (z, y, x))], axis=0
        )
        pos = flat[inside]
        first = pos[x[pos] == band.start[2]]
        want = first + (band.size[2] if band.size[2] > 1 else 1)
        np.testing.assert_array_equal(rows.end[first], want)
    q = np.random.default_rng(1).integers(-3, 4, shape) * (
        np.random.default_rng(2).random(shape) < 0.2
    )
    q[:, : shape[1] // 2] = 0  # whole zero rows
    for name, coder in CODERS.items():
        out = np.empty(shape, np.int64)
        coder.decode(coder.encode(q.copy(), rows), rows, out)
        np.testing.assert_array_equal(out, q, err_msg=name)
