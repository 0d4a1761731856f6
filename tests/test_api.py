"""Volume <-> .vpk through the brick pipeline: round trips, regions, workers, stability."""

from __future__ import annotations

import io

import numpy as np
import pytest
from conftest import smooth_volume
from hypothesis import given
from hypothesis import strategies as st

from volpack import api
from volpack.errors import FormatError
from volpack.volume import Volume
from volpack.volume_codec import bricks
from volpack.volume_codec.codec import CODER_NAMES, WAVELET_NAMES, WaveletCodec

INT_DTYPES = [np.uint8, np.int8, np.uint16, np.int16, np.uint32, np.int32]


def roundtrip(a, **opts):
    blob = api.compress_array(a, **opts)
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype and back.shape == a.shape
    np.testing.assert_array_equal(back, a)
    return blob


@pytest.mark.parametrize("wavelet", WAVELET_NAMES)
@pytest.mark.parametrize("coder", CODER_NAMES)
@pytest.mark.parametrize("order", ["dfs", "line"])
def test_every_wavelet_coder_order_is_exact(wavelet, coder, order):
    a = smooth_volume((19, 23, 29), np.int16, seed=1)
    roundtrip(a, wavelet=wavelet, coder=coder, order=order, brick=16)


@pytest.mark.parametrize("dtype", INT_DTYPES)
def test_extreme_values_every_dtype(dtype):
    info = np.iinfo(dtype)
    z, y, x = np.indices((9, 10, 11))
    checker = np.where((z + y + x) % 2 == 0, info.min, info.max).astype(dtype)
    for coder in CODER_NAMES:
        roundtrip(checker, coder=coder, brick=8)
    r = np.random.default_rng(3)
    full = r.integers(info.min, info.max, size=(7, 12, 13), endpoint=True, dtype=dtype)
    roundtrip(full, brick=(4, 8, 16))


@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 17), (1, 13, 1), (2, 3, 5), (7, 11, 13), (31, 1, 37)]
)
def test_odd_prime_and_degenerate_shapes(shape):
    a = smooth_volume(shape, np.uint16, seed=2)
    for coder in CODER_NAMES:
        roundtrip(a, coder=coder, brick=8)


def test_white_noise_costs_at_most_a_small_overhead():
    a = np.random.default_rng(4).integers(0, 256, size=(64, 64, 64), dtype=np.uint8)
    blob = roundtrip(a, brick=32)
    # 8 bricks: one mode byte and a 24-byte chunk record each, plus header, index and footer
    assert len(blob) <= a.nbytes + 8 * 40 + 2048


def test_constant_and_zero_volumes_cost_a_few_bytes_per_brick():
    for value in (0, 1234):
        a = np.full((64, 64, 64), value, dtype=np.int16)
        blob = api.compress_array(a, brick=32)
        with api_reader(blob) as r:
            assert all(e.nbytes <= 4 for e in r.entries)
        np.testing.assert_array_equal(api.decompress_array(blob), a)


def api_reader(blob):
    from volpack.format.container import Reader

    return Reader(blob)


def test_roi_reads_only_the_bricks_it_touches(tmp_path):
    a = smooth_volume((40, 50, 60), np.int16, seed=5)
    path = str(tmp_path / "v.vpk")
    api.compress(a, path, brick=16)
    roi = (slice(3, 20), slice(17, 18), slice(33, 60))
    got = api.decompress(path, roi="3:20,17:18,33:60")
    np.testing.assert_array_equal(got.data, a[roi])
    assert got.origin == (3.0, 17.0, 33.0)
    assert len(bricks.bricks_in_roi(a.shape, (16, 16, 16), roi)) == 2 * 1 * 2


@pytest.mark.parametrize(
    "z0,y0,x0", [(0, 0, 0), (15, 15, 15), (16, 16, 16), (31, 47, 59), (39, 49, 59)]
)
def test_bricks_at_every_edge_position(z0, y0, x0, tmp_path):
    a = smooth_volume((40, 50, 60), np.uint16, seed=6)
    blob = api.compress_array(a, brick=16)
    roi = f"{z0}:{z0 + 1},{y0}:,{x0}:{x0 + 1}"
    got = api.decompress(blob, roi=roi).data
    np.testing.assert_array_equal(got, a[z0 : z0 + 1, y0:, x0 : x0 + 1])


def test_bytes_do_not_depend_on_worker_count():
    a = smooth_volume((70, 40, 50), np.int16, seed=7)
    one = api.compress_array(a, brick=16, workers=1)
    for workers in (2, 3):
        assert api.compress_array(a, brick=16, workers=workers) == one
    np.testing.assert_array_equal(api.decompress_array(one, workers=2), a)


def test_four_dimensional_frames_and_frame_access():
    a = np.stack([smooth_volume((9, 10, 11), np.int16, seed=s) for s in range(3)])
    blob = roundtrip(a, brick=8)
    np.testing.assert_array_equal(api.decompress(blob, frame=1).data, a[1])
    with pytest.raises(FormatError, match="frame"):
        api.decompress(blob, frame=3)


def test_floats_are_stored_exactly_or_refused_with_a_pointer_to_max_error():
    a = np.random.default_rng(8).normal(size=(9, 10, 11)).astype(np.float32)
    a[0, 0, :3] = [np.nan, np.inf, -np.inf]
    back = api.decompress_array(api.compress_array(a))
    assert back.tobytes() == a.tobytes()
    with pytest.raises(FormatError, match="max_error"):
        api.compress_array(a, codec="wavelet")


def test_spacing_origin_and_meta_travel_with_the_data():
    v = Volume(
        smooth_volume((5, 6, 7)), spacing=(1.5, 0.9, 0.9), origin=(1, 2, 3), meta={"scan": "x"}
    )
    buf = io.BytesIO()
    api.compress(v, buf)
    got = api.decompress(buf.getvalue())
    assert (
        got.spacing == (1.5, 0.9, 0.9)
        and got.origin == (1.0, 2.0, 3.0)
        and got.meta == {"scan": "x"}
    )


def test_info_reads_bytes_as_it_reads_a_file(tmp_path):
    blob = api.compress_array(smooth_volume((5, 6, 7)))
    path = tmp_path / "v.vpk"
    path.write_bytes(blob)
    from_bytes = api.info(blob)
    from_file = api.info(str(path))
    assert from_file.pop("path") == str(path) and from_bytes.pop("path") == "-"
    assert from_bytes == from_file
    assert from_bytes["header"]["shape"] == [5, 6, 7]


@pytest.mark.slow  # 10 CPU s coding a whole MRI
def test_lossless_beats_raw_on_a_real_mri(brain):
    for coder in CODER_NAMES:
        blob = roundtrip(brain, coder=coder)
        assert brain.nbytes / len(blob) > 2.0, coder


@pytest.mark.parametrize("coder", CODER_NAMES)
def test_corrupt_brick_payload_never_crashes(coder):
    a = smooth_volume((20, 20, 20), np.int16, seed=9)
    c = WaveletCodec(coder=coder)
    good = c.encode(a)
    r = np.random.default_rng(10)
    outcomes = set()
    for k in range(80):
        bad = bytearray(good)
        if k % 4 == 0:
            bad = bad[: int(r.integers(len(bad)))]  # truncation
        else:
            i = int(r.integers(1, len(bad)))
            bad[i] ^= 1 << int(r.integers(8))
        try:
            out = c.decode(bytes(bad), a.shape, a.dtype)
            assert out.shape == a.shape and out.dtype == a.dtype
            outcomes.add("decoded")
        except FormatError:
            outcomes.add("error")
    assert "error" in outcomes  # truncations at least must be noticed


def test_corrupt_container_is_caught_by_checksums():
    a = smooth_volume((20, 20, 20), np.int16, seed=9)
    blob = bytearray(api.compress_array(a, brick=20))
    blob[len(blob) // 2] ^= 0xFF
    with pytest.raises(FormatError):
        api.decompress_array(bytes(blob))


@given(
    shape=st.tuples(*(st.integers(1, 12),) * 3),
    dtype=st.sampled_from(INT_DTYPES),
    coder=st.sampled_from(CODER_NAMES),
    wavelet=st.sampled_from(WAVELET_NAMES),
    seed=st.integers(0, 2**16),
)
def test_property_round_trip(shape, dtype, coder, wavelet, seed):
    info = np.iinfo(dtype)
    r = np.random.default_rng(seed)
    lo, hi = int(info.min), int(info.max)
    if seed % 2:  # small-range data, like real scans
        lo, hi = max(lo, -50), min(hi, 50)
    a = r.integers(lo, hi, size=shape, endpoint=True).astype(dtype)
    c = WaveletCodec(wavelet=wavelet, coder=coder, order="dfs" if seed % 3 else "line")
    np.testing.assert_array_equal(c.decode(c.encode(a), a.shape, a.dtype), a)
