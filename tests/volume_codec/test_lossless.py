"""The lossless codec: per-brick tools, 3-D prediction, palettes, floats bit for bit,
golden streams and corrupt payloads."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import flip_bits, float_specials, slow_case

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import palette, predict
from volpack.volume_codec.floatbits import from_ordered, to_ordered
from volpack.volume_codec.lossless import (
    FLAG_FIT,
    FLAG_FLOAT,
    FLAG_LABELS,
    FLAG_LOW,
    FLAG_MORE,
    FLAG_PALETTE,
    FLAG_SPLIT,
    FLAG_TEX,
    MODE_PREDICT,
    LosslessCodec,
    _encode_predict,
)

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"


def roundtrip(a, **opts):
    blob = api.compress_array(a, **opts)
    back = api.decompress_array(blob)
    assert back.dtype == a.dtype and back.shape == a.shape
    assert np.array_equal(back.view(f"u{a.itemsize}"), a.view(f"u{a.itemsize}"))
    with Reader(blob) as r:
        return blob, r.summary.get("tools", {})


def smooth(shape, seed=0, noise=2):
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    return 60 + 40 * np.sin(x / 5.0) * np.cos(y / 7.0) + z + rng.normal(0, noise, shape)


# --- prediction --------------------------------------------------------------------------


@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 9), (1, 7, 1), (5, 1, 1), (3, 4, 5), (9, 17, 13)]
)
def test_predict_roundtrip_every_shape(shape):
    v = np.rint(smooth(shape)).astype(np.int64)
    lo, hi = int(v.min()), int(v.max())
    back = predict.decode(predict.encode(v, lo, hi), shape, lo, hi)
    np.testing.assert_array_equal(back, v)


def test_predict_extreme_range():
    rng = np.random.default_rng(3)
    v = rng.integers(-(2**31), 2**31, (6, 7, 8), dtype=np.int64)
    v[0, 0, 0], v[-1, -1, -1] = -(2**31), 2**31 - 1
    back = predict.decode(predict.encode(v, -(2**31), 2**31 - 1), v.shape, -(2**31), 2**31 - 1)
    np.testing.assert_array_equal(back, v)


def test_predict_floor_division_is_exact():
    """The blend's float-corrected division equals Python's floor division over the
    whole range it serves: weighted means of predictions of 32-bit values (quotients
    up to 2^35 in magnitude; the predictors reach 2^34), denominators of six weights of
    up to 2^24 each, numerators on, just below and just above multiples."""
    rng = np.random.default_rng(11)
    d = rng.integers(6, 6 * 2**24 + 1, 20000)
    q = rng.integers(-(2**35), 2**35, d.size)
    r = rng.integers(0, d)
    a = q * d + r  # quotient q, remainder r: every case, exact integers near and on
    a = np.concatenate([a, q * d, q * d - 1, q * d + d - 1])
    d = np.concatenate([d, d, d, d])
    got = np.array([predict.floor_div(int(x), int(y)) for x, y in zip(a, d)])
    np.testing.assert_array_equal(got, a // d)
    # The truncating variant of version 2 (non-negative numerators only), same cases.
    keep = a >= 0
    got = np.array([predict.floor_div_nonneg(int(x), int(y)) for x, y in zip(a[keep], d[keep])])
    np.testing.assert_array_equal(got, a[keep] // d[keep])
    # By the reciprocal the caller worked out (version 2's blend), same cases.
    got = np.array([predict.floor_div_recip(int(x), int(y), 1.0 / y) for x, y in zip(a[keep], d[keep])])
    np.testing.assert_array_equal(got, a[keep] // d[keep])


def test_predict_beats_wavelet_on_an_edge():
    """A sharp-edged object on a zero background: prediction pays the edge once."""
    a = np.clip(np.rint(smooth((32, 32, 32), noise=1)), 1, 255).astype(np.uint8)
    z, y, x = np.indices(a.shape)
    a[(z - 16) ** 2 + (y - 16) ** 2 + (x - 16) ** 2 > 12**2] = 0
    wave, _ = roundtrip(a, codec="wavelet", brick=32)
    pred, tools = roundtrip(a, brick=32, tools="predict")
    assert len(pred) < 0.9 * len(wave)
    auto, _ = roundtrip(a, brick=32)
    assert len(auto) <= min(len(pred), len(wave))


def test_auto_keeps_the_shortest_tool_per_brick():
    a = np.clip(np.rint(smooth((16, 16, 32), noise=4)), 0, 255).astype(np.uint8)
    codec = LosslessCodec()
    for sl in (np.s_[:, :, :16], np.s_[:, :, 16:]):
        b = np.ascontiguousarray(a[sl])
        got = len(codec.encode(b))
        for tools in ("wavelet", "predict"):
            assert got <= len(LosslessCodec(tools=tools).encode(b))


# --- palettes ----------------------------------------------------------------------------


@pytest.mark.parametrize("k", [1, 2, 255, 256, 65536])
def test_palette_pack_unpack(k):
    rng = np.random.default_rng(k)
    p = np.unique(rng.integers(-(2**31), 2**31, 3 * k))[:k]
    while len(p) < k:  # a second draw in the rare case of collisions
        p = np.unique(np.concatenate([p, rng.integers(-(2**31), 2**31, k)]))[:k]
    got, used = palette.unpack(memoryview(palette.pack(p)), 1 << 16)
    np.testing.assert_array_equal(got, p)
    assert used == len(palette.pack(p))


def test_palette_one_byte_gaps_and_their_errors():
    # gaps below 128 take the vectorised path: values, bytes used (trailing bytes left),
    # a multi-byte gap among them, a truncated palette, a value past 2^63 - 1
    rng = np.random.default_rng(5)
    p = np.cumsum(rng.integers(1, 129, 300)) - 1000
    for q in (p, np.concatenate([p, [p[-1] + 500]])):
        body = palette.pack(q)
        got, used = palette.unpack(memoryview(body + b"\x07"), 1 << 16)
        np.testing.assert_array_equal(got, q)
        assert used == len(body)
    with pytest.raises(FormatError, match="ends inside"):
        palette.unpack(memoryview(palette.pack(p)[:-1]), 1 << 16)
    top = np.array([2**63 - 3, 2**63 - 2, 2**63 - 1])
    np.testing.assert_array_equal(palette.unpack(memoryview(palette.pack(top)), 8)[0], top)
    with pytest.raises(FormatError, match="64-bit range"):
        palette.unpack(memoryview(palette.pack(top)[:-1] + b"\x01"), 8)


def test_palette_multi_byte_gaps_read_as_value_by_value():
    """Gaps of one to ten LEB128 bytes (numpy passes up to six, the loop beyond), whole,
    cut, bit-flipped and followed by other bytes: the same values and bytes used as a
    plain reading of the format (naive.palette_unpack), or the same error."""
    from naive import palette_unpack

    rng = np.random.default_rng(11)
    seen = set()
    for t in range(6000):
        scale = (2, 200, 2**20, 2**40, 2**50, 2**62)[t % 6]
        q = np.cumsum(rng.integers(1, scale, int(rng.integers(1, 60))))
        q = q - int(rng.integers(0, 2**40)) + (2**62 if t % 11 == 0 else 0)
        if q[-1] >= 2**63 - 1 or q[0] < -(2**63):
            continue
        d = bytearray(palette.pack(q))
        if t % 4 == 1:
            d = d[: rng.integers(0, len(d) + 1)]
        elif t % 4 == 2:
            for j in rng.integers(0, len(d), 2):
                d[j] ^= 1 << int(rng.integers(0, 8))
        elif t % 4 == 3:
            d += rng.integers(0, 256, 5).astype(np.uint8).tobytes()
        limit = 8 if t % 7 == 0 else 64
        try:
            want = palette_unpack(bytes(d), limit)
        except FormatError as e:
            with pytest.raises(FormatError, match=re.escape(str(e))):
                palette.unpack(memoryview(bytes(d)), limit)
            seen.add(str(e).split(":")[1][:12])
            continue
        got, used = palette.unpack(memoryview(bytes(d)), limit)
        assert (got.tolist(), used) == want
        seen.add("read")
    assert len(seen) == 5  # read, and each of the four errors


@pytest.mark.parametrize(
    "k,dtype", [(2, np.uint8), (255, np.uint8), (256, np.uint16), (65536, np.int32)]
)
def test_palette_volumes_roundtrip(k, dtype):
    rng = np.random.default_rng(k)
    n = max(k, 4096)
    shape = (n // 1024, 32, 32)
    top = {np.uint8: 255, np.uint16: 3 * 255, np.int32: 200_000}[dtype]
    values = np.unique(np.rint(np.linspace(-top // 2 if dtype == np.int32 else 0, top, k)))
    assert len(values) == k and np.diff(values).max() > 1  # k values with gaps
    values = values.astype(np.int64)
    idx = np.concatenate([np.arange(k), rng.integers(0, k, n - k)])
    a = values[np.sort(idx)].reshape(shape).astype(dtype)
    roundtrip(a, brick=(shape[0], 32, 32), tools="predict")
    # Both predictive payloads, with and without the palette, decode exactly.
    payloads = _encode_predict(a)
    assert [p[1] & FLAG_PALETTE for p in payloads[:2]] == [0, FLAG_PALETTE]
    for p in payloads:
        back = LosslessCodec().decode(p, a.shape, a.dtype)
        np.testing.assert_array_equal(back, a)


def test_palette_of_one_value_is_a_constant_brick():
    a = np.full((8, 8, 8), 77, np.uint16)
    blob, tools = roundtrip(a, brick=8)
    assert tools == {"constant": 1}


# --- backgrounds -------------------------------------------------------------------------


def _background_cases():
    base = np.clip(np.rint(smooth((20, 24, 28))), 1, 255).astype(np.uint8)
    full = np.zeros_like(base)
    one = full.copy()
    one[7, 9, 11] = 200
    checker = base * (np.indices(base.shape).sum(axis=0) % 2).astype(np.uint8)
    edges = base.copy()  # background on every brick face (brick 8)
    for ax in range(3):
        sl = [slice(None)] * 3
        sl[ax] = slice(0, None, 8)
        edges[tuple(sl)] = 0
        sl[ax] = slice(7, None, 8)
        edges[tuple(sl)] = 0
    corner = base.copy()
    corner[:8, :8, :8] = 0  # one brick entirely background
    return {"empty": base, "full": full, "one": one, "checker": checker, "edges": edges,
            "brick": corner}  # fmt: skip


@pytest.mark.parametrize("name", list(_background_cases()))
def test_background_patterns_roundtrip(name):
    a = _background_cases()[name]
    blob, tools = roundtrip(a, brick=8)
    if name == "full":
        assert tools == {"constant": 36}
    if name == "brick":
        with Reader(blob) as r:
            assert r.read(0, 0)[0] == 2  # the background brick is one value


def test_flat_background_costs_little():
    a = np.zeros((32, 32, 32), np.uint8)
    a[10:20, 10:20, 10:20] = np.clip(np.rint(smooth((10, 10, 10))), 1, 255)
    blob, _ = roundtrip(a, brick=32, tools="predict")
    alone, _ = roundtrip(np.ascontiguousarray(a[10:20, 10:20, 10:20]), brick=32, tools="predict")
    # 31,768 background voxels cost well under a tenth of a bit each
    assert len(blob) - len(alone) < 0.1 * (a.size - 1000) / 8


def label_map(shape=(24, 28, 32), seed=4):
    """Nested shells of 7 labels around two centres, as an atlas draws regions."""
    z, y, x = np.indices(shape)
    d1 = np.sqrt((z - 8) ** 2 + (y - 9) ** 2 + (x - 10) ** 2)
    d2 = np.sqrt((z - 16) ** 2 + (y - 20) ** 2 + (x - 22) ** 2)
    lab = np.minimum(d1 // 3, 3) * 2 + (d2 < 7) * 11
    return (lab * 9 + 5).astype(np.uint8)


def test_label_maps_copy_neighbours():
    from volpack.volume_codec.codec import WaveletCodec, ZstdCodec

    a = label_map()
    blob, tools = roundtrip(a, brick=32)
    assert tools == {"labels": 1}
    ours = len(LosslessCodec().encode(a))
    assert ours < 0.7 * min(len(ZstdCodec().encode(a)), len(WaveletCodec().encode(a)))
    a16 = a.astype(np.int16) * 300 - 20000  # the same labels as wide values
    blob16, tools16 = roundtrip(a16, brick=32)
    assert tools16 == {"labels": 1} and len(LosslessCodec().encode(a16)) < ours + 16


# past 256 labels the decoder runs a signature of its own
@pytest.mark.parametrize("k", [1, 2, 256, slow_case(257), slow_case(4096)])
def test_label_decoder_runs_ranks_and_palette(k):
    """The label decoder's paths against the encoder: flat runs (one model held in a
    register) broken by single voxels, by a label change mid-run and at every brick face;
    ranks come back in the narrowest type (uint8 up to 256 labels, else uint16), and
    with a palette as ``palette[rank]`` in the palette's dtype."""
    from volpack.volume_codec import labels

    rng = np.random.default_rng(k)
    shape = (9, 11, 13)
    a = np.repeat(rng.integers(0, k, (3, 11, 13)), 3, axis=0)  # runs across slices
    a[:, 4:7, 2:11] = k - 1  # a flat block, broken below by lone voxels
    a[5, 5, 5], a[6, 4, 2], a[7, 6, 10] = 0, k // 2, k // 3
    a[:, :, -1] = rng.integers(0, k, (9, 11))  # the last column (no NE) differs
    stream = labels.encode(a, k)
    ranks = labels.decode(stream, shape, k)
    assert ranks.dtype == (np.uint8 if k <= 256 else np.uint16)
    np.testing.assert_array_equal(ranks, a)
    p = np.sort(rng.choice(np.arange(-40000, 40000), k, replace=False)).astype(np.int32)
    values = labels.decode(stream, shape, k, p)
    assert values.dtype == np.int32
    np.testing.assert_array_equal(values, p[a])


# --- floats ------------------------------------------------------------------------------


def special_floats(dtype=np.float32):
    f = (smooth((12, 14, 16)) / 7).astype(dtype)
    flat = f.reshape(-1)
    info = np.finfo(dtype)
    flat[:8] = [np.nan, -np.nan, np.inf, -np.inf, -0.0, 0.0, info.smallest_subnormal, -info.tiny]
    bits = flat.view(f"u{f.itemsize}")
    bits[8] = bits[0] | 1  # a NaN with a payload
    flat[9] = info.max
    flat[10] = -info.max
    return f


@pytest.mark.parametrize("dtype", [np.float32, slow_case(np.float16)])
def test_floats_bit_exact(dtype):
    a = special_floats(dtype)
    roundtrip(a, brick=8)
    roundtrip(a, brick=8, tools="predict")


def test_float_ordering_map():
    a = np.array([-np.inf, -1.0, -1e-42, -0.0, 0.0, 1e-42, 1.0, np.inf, np.nan], np.float32)
    o = to_ordered(a)
    assert (np.diff(o) > 0).all()
    np.testing.assert_array_equal(from_ordered(o, np.float32).view(np.uint32), a.view(np.uint32))


@pytest.mark.slow  # the float decoder's kernels: see SLOW_CASES
def test_float_field_beats_byte_shuffled_zstd():
    """A signed field crossing zero with full mantissas: exponent and mantissa apart."""
    rng = np.random.default_rng(2)
    z, y, x = np.indices((32, 32, 32))
    f = (x - 15.5) * 0.3 + (y - 12) * (z - 20) * 0.01 + rng.normal(0, 0.01, z.shape)
    f = f.astype(np.float32)
    lossless, tools = roundtrip(f, brick=32, predict_version=2)  # version 3: mode 5 too
    zstd, _ = roundtrip(f, codec="zstd", brick=32)
    assert len(lossless) < 0.95 * len(zstd)
    assert tools == {"predict-float": 1}


# --- golden streams ----------------------------------------------------------------------

# The recipes of scripts/make_examples.py, written out again on purpose.
V1 = {"predict_version": 1}
CASES = [
    ("lossless-auto-u8", "u8-background", V1),
    ("lossless-auto-i16-palette", "i16", V1),
    ("lossless-predict-u8", "u8", {"tools": "predict", **V1}),
    ("lossless-auto-f32-special", "f32-special", V1),
    ("lossless-auto-f32-field", "f32-field", V1),
    ("lossless-v2-u8-mask", "v2-u8-background", {"brick": 32, "predict_version": 2}),
    ("lossless-v2-i16-palette", "v2-i16", {"brick": 32, "predict_version": 2}),
    ("lossless-v2-predict-u8", "v2-u8", {"tools": "predict", "brick": 32, "predict_version": 2}),
    ("lossless-v5-u8-floor", "v5-u8-floor", {"brick": 32, "predict_version": 5}),
    ("lossless-v7-u8-tex", "v2-u8", {"brick": 32, "predict_version": 7}),
    # version 8: the mixed estimates (flag 256: a second flags byte), one brick
    ("lossless-v8-u8-mix", "v2-u8", {"brick": 32, "predict_version": 8}),
    # version 9: the local fit (flag 512), alone, with a mask, with the palette
    ("lossless-v9-u8-local", "v2-u8", {"brick": 32, "predict_version": 9}),
    ("lossless-v9-u8-local-mask", "v2-u8-background", {"brick": 32, "predict_version": 9}),
    ("lossless-v9-i16-local-palette", "v2-i16", {"brick": 32, "predict_version": 9}),
]


def golden_source(recipe):
    from volpack.demo import load_demo_volume

    d = load_demo_volume().data
    if recipe == "v5-u8-floor":  # the cut below over a fixed noise floor of 0..5
        cut = golden_source("v2-u8-background")
        z, y, x = np.indices(cut.shape)
        table = np.array([0, 2, 3, 3, 3, 4, 2, 0, 3, 5, 1, 3, 2], dtype=np.uint8)
        return np.where(cut == 0, table[(z * 131 + y * 71 + x * 37 + (x * y) % 11) % 13], cut)
    if recipe == "v2-u8-background":
        cut = d[16:48, 24:56, 24:56].copy()
        cut[cut < 60] = 0
        return cut
    if recipe in ("v2-u8", "v2-i16"):
        cut = np.ascontiguousarray(d[30:62, 40:72, 40:72])
        return cut if recipe == "v2-u8" else cut.astype(np.int16) * 37 - 3000
    cut = d[30:50, 40:64, 40:68]
    if recipe == "u8":
        return cut
    if recipe == "i16":
        return cut.astype(np.int16) * 37 - 3000
    if recipe == "f32-field":
        z, y, x = np.indices((20, 24, 28))
        f = cut * 1.37 - 40.0 + z * 0.011 + y * y * 0.0007 - x * 0.05
        return f.astype(np.float32)
    if recipe == "u8-background":
        cut = cut.copy()
        cut[cut < 60] = 0
        return cut
    return float_specials(cut)


# cases whose kernels (the local fit's general decoder, the float decoder) only a few fast
# tests compile: slow set (results/tests/kernel_use36.md)
SLOW_CASES = {
    "lossless-auto-f32-field",
    "lossless-v9-u8-local",
    "lossless-v9-u8-local-mask",
    "lossless-v9-i16-local-palette",
}


@pytest.mark.parametrize(
    "stem,recipe,opts",
    [pytest.param(*c, id=c[0], marks=[pytest.mark.slow] if c[0] in SLOW_CASES else []) for c in CASES],
)
def test_golden_lossless_stream(stem, recipe, opts):
    blob = (GOLDEN / f"{stem}.vpk").read_bytes()
    want = golden_source(recipe)
    got = api.decompress(blob).data
    assert got.dtype == want.dtype
    np.testing.assert_array_equal(got.view(f"u{want.itemsize}"), want.view(f"u{want.itemsize}"))
    again = api.compress_array(want, **{"brick": 16, **opts})
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_golden_lossless_streams_use_the_new_sections():
    seen = set()
    for stem, _, _ in CASES:
        with Reader((GOLDEN / f"{stem}.vpk").read_bytes()) as r:
            for e in r.entries:
                p = r.read(e.t, e.node)
                seen.add((p[0], p[1] if p[0] == MODE_PREDICT else None))
    assert (MODE_PREDICT, 0) in seen
    assert (MODE_PREDICT, FLAG_PALETTE) in seen
    assert (MODE_PREDICT, FLAG_FLOAT | FLAG_PALETTE) in seen
    assert (MODE_PREDICT, FLAG_FLOAT | FLAG_SPLIT) in seen
    assert (MODE_PREDICT, FLAG_PALETTE | FLAG_LABELS) in seen
    assert (MODE_PREDICT, FLAG_FIT | FLAG_PALETTE | FLAG_LOW) in seen
    assert (MODE_PREDICT, FLAG_FIT | FLAG_LOW | FLAG_TEX) in seen
    assert (MODE_PREDICT, FLAG_FIT | FLAG_LOW | FLAG_TEX | FLAG_MORE) in seen  # MIX


# --- corrupt payloads --------------------------------------------------------------------


def _payload(a, **opts):
    return LosslessCodec(**opts).encode(a)


def test_corrupt_sections_raise_format_error():
    codec = LosslessCodec()
    a = np.rint(smooth((6, 7, 8))).astype(np.uint8)
    good = _payload(a, tools="predict")
    assert good[0] == MODE_PREDICT
    bad = [
        b"",  # no mode byte
        bytes([MODE_PREDICT]),  # no flags
        bytes([MODE_PREDICT, 0x80]) + good[2:],  # unknown flag
        bytes([MODE_PREDICT, FLAG_FLOAT]) + good[2:],  # float flag on integers
        bytes([9]) + good[1:],  # unknown mode
        good[:3],  # the value range cut short
        bytes([MODE_PREDICT, 0]) + palette.uleb(0) + palette.uleb(1000),  # past uint8
        bytes([MODE_PREDICT, FLAG_PALETTE]) + palette.uleb(0),  # empty palette
        bytes([MODE_PREDICT, FLAG_LABELS]) + good[2:],  # labels without a palette
        bytes([MODE_PREDICT, FLAG_PALETTE | FLAG_LABELS]) + palette.uleb(2) + b"\x00\x00",
        bytes([MODE_PREDICT, FLAG_PALETTE]) + palette.uleb(5000),  # more values than voxels
        bytes([MODE_PREDICT, FLAG_PALETTE]) + palette.uleb(3) + b"\x00\x80",  # cut short
        bytes([MODE_PREDICT, FLAG_PALETTE]) + palette.uleb(2) + palette.uleb(600) + b"\x00",
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)


def test_bit_flips_raise_or_decode():
    codec = LosslessCodec()
    rng = np.random.default_rng(5)
    for a in (
        np.rint(smooth((6, 7, 8))).astype(np.uint8),
        (np.rint(smooth((6, 7, 8))) * 16).astype(np.int16),
        special_floats()[:6, :7, :8].copy(),
    ):
        good = bytearray(_payload(a, tools="predict"))
        flip_bits(codec, good, a, rng, 30)


def test_truncated_stream_raises():
    codec = LosslessCodec()
    a = np.rint(smooth((16, 16, 16), noise=8)).astype(np.uint8)
    good = _payload(a, tools="predict")
    with pytest.raises(FormatError):
        codec.decode(good[: len(good) // 2], a.shape, a.dtype)


def test_info_names_the_tools(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    a = _background_cases()["brick"]
    path = tmp_path / "a.vpk"
    path.write_bytes(api.compress_array(a, brick=8))
    out = CliRunner().invoke(main, ["info", str(path)])
    assert out.exit_code == 0, out.output
    assert "tools" in out.output and "constant 1" in out.output
