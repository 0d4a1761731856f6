"""Tuple palettes (session 33, cpal33): a (z, y, x, c) or (c, z, y, x) integer volume of
few distinct voxel tuples (a scan through a colour map, labels in colours) stored as the
palette of its tuples (chunk (1, 0)) and the 3-D volume of each voxel's index, header
"channels": {"axis": ..., "tuples": K}. Colin27 through a colour map was 5.17:1 as three
channels against zstd -19's 5.94."""

from __future__ import annotations

import io
import os

import numpy as np
import pytest
from conftest import rewrite_header, smooth_volume

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader, Writer
from volpack.volume_codec import stream
from volpack.volume_codec import tuples as tp
from volpack.volume_codec.lossless import LosslessCodec

GOLDEN = os.path.join(os.path.dirname(__file__), "..", "..", "formats", "examples")


def grey(shape=(12, 40, 44), seed=0) -> np.ndarray:
    """A smooth uint8 field with a little noise: the hidden scan."""
    v = smooth_volume(shape, np.int16, seed).astype(np.float64)
    return np.round((v - v.min()) / (v.max() - v.min()) * 255).astype(np.uint8)


def wheel(g: np.ndarray, alpha: bool = False) -> np.ndarray:
    """``g`` through a colour wheel (its brightness not monotone, colours turning back
    over 0.8 of a turn), RGB or RGBA last."""
    turn = 2 * np.pi * 0.8 * np.arange(256) / 255
    lut = [127.5 + 127 * np.cos(turn + k * 2 * np.pi / 3) for k in range(3)]
    if alpha:
        lut.append(np.minimum(3 * np.arange(256), 255))
    return np.stack(lut, -1).astype(np.uint8)[g]


def header(blob: bytes) -> dict:
    with Reader(blob) as r:
        return r.header


def rewrite_chunks(blob: bytes, change) -> bytes:
    """``blob`` with its chunks passed through ``change(t, node, payload)`` (None drops
    the chunk), header and summary kept."""
    with Reader(blob) as r:
        hdr, summ = dict(r.header), r.summary
        chunks = [(t, n, bytes(r.read(t, n))) for t, n in r.keys()]
    buf = io.BytesIO()
    w = Writer(buf, hdr)
    for t, n, p in chunks:
        p = change(t, n, p)
        if p is not None:
            w.write(t, n, p)
    w.close(summ)
    return buf.getvalue()


def check_reads(a: np.ndarray, blob: bytes, axis: str) -> None:
    """The whole volume, every channel as a frame and a region come back exactly."""
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype and back.shape == a.shape
    np.testing.assert_array_equal(back, a)
    nc = a.shape[-1] if axis == "last" else a.shape[0]
    for ch in range(nc):
        want = a[..., ch] if axis == "last" else a[ch]
        np.testing.assert_array_equal(stream.decompress(blob, frame=ch).data, want)
    part = stream.decompress(blob, roi="2:7,3:20,5:29").data
    want = a[2:7, 3:20, 5:29] if axis == "last" else a[:, 2:7, 3:20, 5:29]
    np.testing.assert_array_equal(part, want)


@pytest.mark.parametrize(
    "make",
    [
        lambda: wheel(grey()),  # RGB
        lambda: wheel(grey(), alpha=True),  # RGBA
        lambda: np.stack([grey().astype(np.int16) * 7 - 900, -3 * grey().astype(np.int16)], -1),
    ],
    ids=["rgb", "rgba", "two-int16"],
)
def test_palette_round_trips_and_is_shorter_than_the_channels(make):
    a = make()
    buf = io.BytesIO()
    st = stream.compress(a, buf, brick=16)
    blob = buf.getvalue()
    k = len(np.unique(a.reshape(-1, a.shape[-1]), axis=0))
    assert header(blob)["channels"] == {"axis": "last", "tuples": k}
    assert st["tuples"] == k and st["tuple_order"] in tp.ORDERS
    check_reads(a, blob, "last")
    without = api.compress_array(a, brick=16, tuples=False)
    assert header(without)["channels"] == "last"
    assert len(blob) < 0.7 * len(without), (len(blob), len(without))


def test_channels_first_round_trip():
    a = np.ascontiguousarray(np.moveaxis(wheel(grey()), -1, 0))
    blob = api.compress_array(a, brick=16)
    assert header(blob)["channels"]["axis"] == "first"
    check_reads(a, blob, "first")
    assert len(blob) < 0.7 * len(api.compress_array(a, brick=16, tuples=False))


@pytest.mark.parametrize("k", [1, 2, 256, 257])
def test_palettes_of_one_to_257_tuples(k):
    """1 tuple (a constant colour), 256 (the last uint8 index) and 257 (uint16)."""
    v = smooth_volume((12, 40, 44)).reshape(-1)
    rank = np.empty(v.size, np.int64)
    rank[np.argsort(v, kind="stable")] = np.arange(v.size)
    g = (rank * k // v.size).reshape(12, 40, 44)  # a monotone map of v onto 0..k-1
    assert len(np.unique(g)) == k
    a = np.stack([g % 256, g // 256 * 40 + 3, 255 - g % 256], -1).astype(np.uint8)
    blob = api.compress_array(a, brick=16, tuples=True)
    assert header(blob)["channels"] == {"axis": "last", "tuples": k}
    check_reads(a, blob, "last")


@pytest.mark.slow
def test_65536_tuples_make_a_palette_and_65537_fall_back():
    n = 8 * 80 * 820  # enough voxels for 8 a tuple
    for k, want in ((65536, {"axis": "last", "tuples": 65536}), (65537, "last")):
        i = np.arange(n) % k
        a = np.stack([i >> 8, i & 255], -1).astype(np.uint16).reshape(8, 80, 820, 2)
        blob = api.compress_array(a, tuples=True)
        assert header(blob)["channels"] == want
        np.testing.assert_array_equal(api.decompress_array(blob), a)


def test_noise_and_too_many_tuples_per_voxel_keep_the_channels():
    rng = np.random.default_rng(1)
    noise = rng.integers(0, 256, (10, 26, 30, 3), dtype=np.uint8)
    assert tp.find(np.ascontiguousarray(np.moveaxis(noise, -1, 0))) is None
    assert header(api.compress_array(noise))["channels"] == "last"
    # int32 tuples of 3 channels need 96 bits: no palette
    wide = wheel(grey()).astype(np.int32)
    assert tp.find(np.ascontiguousarray(np.moveaxis(wide, -1, 0))) is None
    assert header(api.compress_array(wide))["channels"] == "last"


def test_same_bytes_at_one_and_two_workers():
    a = wheel(grey((20, 40, 44)), alpha=True)
    one = api.compress_array(a, brick=16, workers=1)
    assert isinstance(header(one)["channels"], dict)
    assert api.compress_array(a, brick=16, workers=2) == one
    np.testing.assert_array_equal(api.decompress_array(one, workers=2), a)


def test_big_endian_voxels_round_trip():
    a = np.stack([grey().astype(np.int16) * 5, grey().astype(np.int16) // 3], -1)
    big = a.astype(">i2")
    blob = api.compress_array(big, brick=16)
    assert isinstance(header(blob)["channels"], dict)
    back = api.decompress_array(blob)
    np.testing.assert_array_equal(back, a)


def test_lossy_settings_and_interleave_keep_the_channels_path():
    a = wheel(grey())
    blob = api.compress_array(a, max_error=2)
    assert header(blob)["channels"] == "last"
    assert np.abs(api.decompress_array(blob).astype(int) - a).max() <= 2
    f = a.astype(np.float32) / 7
    blob = api.compress_array(f, rel_error=1e-3)
    assert np.abs(api.decompress_array(blob) - f).max() <= 1e-3 * float(f.max() - f.min()) * (
        1 + 1e-6
    )
    assert header(api.compress_array(a, interleave=True))["channels"] == "last"
    assert header(api.compress_array(a, max_error=0))["channels"]["tuples"] > 1  # exact


def test_the_chosen_order_recovers_the_hidden_scan():
    """A colour wheel's colours turn back, so sorting them as numbers or by brightness
    scrambles the scan; the chain of neighbouring tuples recovers its order."""
    g = grey((16, 48, 48), seed=3)
    a = np.ascontiguousarray(np.moveaxis(wheel(g), -1, 0))
    tuples, index = tp.find(a)
    orders = tp.candidate_orders(tuples, index)
    value = np.array([np.flatnonzero(np.all(wheel(np.arange(256, dtype=np.uint8)) == t, -1))[0]
                      for t in tuples])  # fmt: skip
    rho = {k: abs(np.corrcoef(np.arange(len(p)), value[p])[0, 1]) for k, p in orders.items()}
    assert rho["settled"] > 0.999 and rho["sorted"] < 0.9, rho
    c = LosslessCodec()

    def size_of(v):
        return len(c.encode(np.ascontiguousarray(v)))

    plan, _ = tp.plan(a, size_of)
    assert plan.order in ("chain", "settled") and plan.estimate < plan.channels_estimate
    np.testing.assert_array_equal(plan.tuples[plan.index], np.moveaxis(a, 0, -1))


def test_pack_unpack_wraps_signed_and_unsigned():
    for dtype in (np.uint8, np.int8, np.uint16, np.int16, np.int32, np.uint32):
        info = np.iinfo(dtype)
        t = np.array([[info.min, info.max], [info.max, info.min], [0, 1]], dtype)
        np.testing.assert_array_equal(tp.unpack(tp.pack(t), 3, 2, dtype), t)


@pytest.fixture(scope="module")
def blob():
    return api.compress_array(wheel(grey()), brick=16)


@pytest.mark.parametrize("damage", ["garbage", "truncated", "one tuple short", "dropped"])
def test_a_corrupt_palette_chunk_is_refused(blob, damage):
    k = header(blob)["channels"]["tuples"]
    change = {
        "garbage": lambda p: b"\x00" * len(p),
        "truncated": lambda p: p[: len(p) // 2],
        "one tuple short": lambda p: tp.pack(tp.unpack(p, k, 3, np.uint8)[:-1]),
        "dropped": lambda p: None,
    }[damage]
    bad = rewrite_chunks(blob, lambda t, n, p: change(p) if t == 1 else p)
    with pytest.raises(FormatError):
        api.decompress_array(bad)
    with pytest.raises(FormatError):  # a pipe: the chunks are read first
        stream.decompress(io.BufferedReader(io.BytesIO(bad)))


def test_an_index_past_the_palette_is_refused(blob):
    k = header(blob)["channels"]["tuples"]
    assert k > 200  # a uint8 index either way
    fewer = rewrite_chunks(
        blob, lambda t, n, p: tp.pack(tp.unpack(p, k, 3, np.uint8)[:200]) if t == 1 else p
    )
    fewer = rewrite_header(fewer, channels={"axis": "last", "tuples": 200})
    with pytest.raises(FormatError, match=r"index: \d+ in a palette of 200 tuples"):
        api.decompress_array(fewer)


@pytest.mark.parametrize(
    "channels",
    [
        {"axis": "middle", "tuples": 5},
        {"axis": "last", "tuples": 0},
        {"axis": "last", "tuples": 65537},
        {"axis": "last", "tuples": True},
        {"axis": "last", "tuples": 5.0},
        {"axis": "last", "tuples": 5, "more": 1},
        {"axis": "first", "tuples": 5},  # a first axis of 12 voxels: 96 bits
        [1, 2],
    ],
)
def test_a_damaged_channels_object_is_refused(blob, channels):
    with pytest.raises(FormatError, match="expected channels"):
        api.decompress_array(rewrite_header(blob, channels=channels))


def test_a_layout_or_float_voxels_with_a_palette_are_refused(blob):
    with pytest.raises(FormatError, match="without a layout"):
        api.decompress_array(rewrite_header(blob, layout="interleaved"))
    with pytest.raises(FormatError, match="expected channels"):
        api.decompress_array(rewrite_header(blob, dtype="<f4"))


def test_the_command_line_says_so(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    a = wheel(grey())
    np.save(tmp_path / "c.npy", a)
    r = CliRunner().invoke(main, ["compress", str(tmp_path / "c.npy"), str(tmp_path / "c.vpk")])
    assert r.exit_code == 0 and "voxel tuples and their index volume" in r.output, r.output
    r = CliRunner().invoke(main, ["info", str(tmp_path / "c.vpk")])
    k = header((tmp_path / "c.vpk").read_bytes())["channels"]["tuples"]
    assert f"stored as a palette of {k} voxel tuples" in r.output, r.output


def golden_sources():
    """scripts/make_examples.py's recipes 'rgba-u8' and 'pair-i16-first', written out
    again on purpose."""
    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    turn = 2 * np.pi * 0.8 * cut.astype(np.float64) / 255
    wheel_ = [127.5 + 127 * np.cos(turn + k * 2 * np.pi / 3) for k in range(3)]
    rgba = np.stack([*wheel_, np.minimum(3 * cut.astype(np.int64), 255)], -1).astype(np.uint8)
    c16 = cut.astype(np.int16)
    z = np.arange(cut.shape[0], dtype=np.int16)[:, None, None]
    pair = np.stack([c16 * 37 - 3000, -2 * c16 + 50 * (z // 5)])
    return {"lossless-tuples-rgba-u8": rgba, "lossless-tuples-first-i16": pair}


@pytest.mark.parametrize("stem", ["lossless-tuples-rgba-u8", "lossless-tuples-first-i16"])
def test_golden_tuple_streams_decode_and_are_reproduced(stem):
    with open(os.path.join(GOLDEN, f"{stem}.vpk"), "rb") as f:
        gold = f.read()
    want = golden_sources()[stem]
    assert isinstance(header(gold)["channels"], dict)
    np.testing.assert_array_equal(api.decompress_array(gold), want)
    again = api.compress_array(want, brick=32, tuples=True)
    with Reader(gold) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, bytes(p)) for t, n, p in old] == [(t, n, bytes(p)) for t, n, p in new]


@pytest.mark.parametrize("dtype", [np.int8, np.uint8, np.int16, np.uint16])
def test_find_sorts_tuples_as_signed_or_unsigned_numbers(dtype):
    """Keys through a table (up to 24 bits) and by a sort (32 bits), signed and not: the
    tuples come out in numeric order, channel 0 first, and index every voxel."""
    info = np.iinfo(dtype)
    vals = np.array([info.min, -1 if info.min else 1, 0, 5, info.max], dtype)
    rng = np.random.default_rng(5)
    a = vals[rng.integers(0, 5, (2, 4, 10, 12))]
    tuples, index = tp.find(a)
    want = sorted({(int(p), int(q)) for p, q in zip(a[0].ravel(), a[1].ravel())})
    assert [tuple(map(int, t)) for t in tuples] == want
    np.testing.assert_array_equal(np.moveaxis(tuples[index], -1, 0), a)
