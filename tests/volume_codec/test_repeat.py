"""Repeated slices (session 34, mode 6): a brick whose slices come in equal runs (a volume
upsampled by nearest neighbour) coded as its shrunk copy."""

from __future__ import annotations

import os

import numpy as np
import pytest
from conftest import slow_case

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import lossless, repeat
from volpack.volume_codec.lossless import MODE_REPEAT, LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def blobs(shape, seed=0, n=12):
    """A label map: nearest of ``n`` random seeds (Voronoi cells), uint8 labels 0..n-1."""
    rng = np.random.default_rng(seed)
    pts = rng.random((n, 3)) * np.array(shape)
    grid = np.stack(np.indices(shape), -1).astype(np.float64)
    d = ((grid[..., None, :] - pts) ** 2).sum(-1)
    return d.argmin(-1).astype(np.uint8)


def upsampled(a, factors, crop=(0, 0, 0)):
    for ax, f in enumerate(factors):
        a = np.repeat(a, f, axis=ax)
    return np.ascontiguousarray(a[crop[0] :, crop[1] :, crop[2] :])


def tools(blob):
    with Reader(blob) as r:
        return r.summary.get("tools", {})


def with_repeat(flag, a, **opts):
    saved = lossless.REPEAT
    lossless.REPEAT = flag
    try:
        return api.compress_array(a, **opts)
    finally:
        lossless.REPEAT = saved


def naive_runs_ok(a, runs):
    """Every slice equals the first of its run (by the runs' definition, written out)."""
    for ax, (k, r) in enumerate(runs):
        for i in range(a.shape[ax]):
            first = 0 if i < r else r + (i - r) // k * k
            if not np.array_equal(np.take(a, i, ax), np.take(a, first, ax)):
                return False
    return True


@pytest.mark.parametrize(
    "factors,crop", [((2, 2, 2), (0, 0, 0)), ((3, 1, 2), (1, 0, 1)), ((1, 4, 1), (0, 3, 0))]
)
def test_find_shrink_expand(factors, crop):
    a = upsampled(blobs((9, 10, 11)), factors, crop)
    runs = repeat.find(a)
    assert runs is not None and naive_runs_ok(a, runs)
    # the runs are at least as long as the upsampling's
    assert all(k % f == 0 for (k, _), f in zip(runs, factors))
    small = repeat.shrink(a, runs)
    assert small.shape == repeat.shape_of(a.shape, runs)
    np.testing.assert_array_equal(repeat.expand(small, runs, a.shape), a)


def test_find_none_on_a_scan_and_blank_margins_kept():
    rng = np.random.default_rng(1)
    assert repeat.find(rng.integers(0, 50, (8, 9, 10)).astype(np.int16)) is None
    a = upsampled(blobs((6, 7, 8)), (2, 2, 2))
    a[:4] = 0  # a blank margin over two runs: the change still falls on a run start
    runs = repeat.find(a)
    assert runs[0][0] % 2 == 0 and naive_runs_ok(a, runs)


# int32, int64 and float64 compile codec kernels no other fast test uses: slow set
@pytest.mark.parametrize(
    "dtype",
    [
        "uint8",
        "uint16",
        "int16",
        slow_case("int32"),
        slow_case("int64"),
        "float32",
        slow_case("float64"),
        "bool",
    ],
)
def test_round_trip_of_upsampled_volumes(dtype):
    lab = blobs((16, 18, 20), seed=3, n=30)
    if dtype == "bool":
        a = lab % 2 == 0
    elif dtype.startswith("float"):
        a = (lab * 1.37 - 4).astype(dtype)
        a[0, 0, 0] = np.nan
    else:
        a = (lab.astype(np.int64) * 517 - (1000 if dtype[0] == "i" else 0)).astype(dtype)
    a = upsampled(a, (2, 3, 2), (1, 2, 0))
    blob = api.compress_array(a, brick=32)
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype and back.shape == a.shape
    np.testing.assert_array_equal(back.view(f"u{a.itemsize}"), a.view(f"u{a.itemsize}"))
    assert any(t.startswith("repeat+") for t in tools(blob))


def test_upsampled_label_map_codes_shorter_and_same_bytes_at_two_workers():
    """Fails without mode 6: the 2x upsampled map costs about as much as the
    original 8x as many voxels would (the label coder meets every border twice)."""
    a = upsampled(blobs((24, 26, 28), seed=5, n=40), (2, 2, 2))
    old = with_repeat(False, a, brick=32, workers=1)
    new = with_repeat(True, a, brick=32, workers=1)
    assert len(new) < 0.75 * len(old)
    assert with_repeat(True, a, brick=32, workers=2) == new
    assert set(tools(new)) <= {"repeat+labels", "constant"}
    np.testing.assert_array_equal(api.decompress_array(new), a)


def test_old_versions_never_write_mode_6():
    a = upsampled(blobs((8, 9, 10)), (2, 2, 2))
    for v in (1, 7):
        assert not any(
            t.startswith("repeat") for t in tools(api.compress_array(a, predict_version=v))
        )


def test_damaged_repeat_headers_are_refused():
    a = upsampled(blobs((8, 9, 10)), (2, 2, 2))
    codec = LosslessCodec()
    payload = codec.encode(a)
    assert payload[0] == MODE_REPEAT
    runs, used = repeat.unpack(memoryview(payload)[1:], a.shape)
    assert runs == ((2, 2), (2, 2), (2, 2))
    assert lossless.inner_mode(payload) == payload[1 + used] != MODE_REPEAT  # (lossy's tiers)
    bad = [
        bytes([MODE_REPEAT]) + repeat.pack(((2, 3), (2, 2), (2, 2))) + payload[1 + used :],  # r > k
        bytes([MODE_REPEAT])
        + repeat.pack(((99, 1), (2, 2), (2, 2)))
        + payload[1 + used :],  # k > n
        bytes([MODE_REPEAT]) + repeat.pack(((2, 2),) * 3) + payload,  # nested
        payload[:3],  # cut in its header
    ]
    for damaged in bad:
        with pytest.raises(FormatError):
            codec.decode(damaged, a.shape, a.dtype)


def test_golden_repeat_stream_decodes_and_is_reproduced():
    """scripts/make_examples.py's recipe 'labels-runs', written out again on purpose."""
    from volpack.demo import load_demo_volume

    d = load_demo_volume().data[30:50, 40:64, 40:68]
    lab = np.digitize(d, [40, 90, 140]).astype(np.uint8)
    want = np.ascontiguousarray(np.repeat(np.repeat(lab, 2, axis=0), 3, axis=2)[1:, :, 2:])
    with open(os.path.join(GOLDEN, "lossless-v8-u8-repeat.vpk"), "rb") as f:
        blob = f.read()
    np.testing.assert_array_equal(api.decompress_array(blob), want)
    assert any(t.startswith("repeat+") for t in tools(blob))
    again = api.compress_array(want, brick=32)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
