"""Lossless float prediction (mode 5 of the lossless codec): the signed ordered map and
the Lorenzo residuals against the naive references, bit-exact round trips of special
values in 16, 32 and 64 bits, the lattice tool, the per-brick choice, golden streams and
corrupt payloads."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import naive
import numpy as np
import pytest
from conftest import flip_bits, float_specials, slow_case

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.volume_codec import bricks, lossless
from volpack.volume_codec import floatpredict as fp
from volpack.volume_codec.lossless import MODE_FLOAT, MODE_ZSTD, LosslessCodec, describe

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"
# float16 and float64 compile kernel variants of their own: their cases run in the slow set
DTYPES = [slow_case(np.float16), np.float32, slow_case(np.float64)]


def same_bits(a, b):
    return (
        a.dtype == b.dtype
        and a.shape == b.shape
        and np.array_equal(a.view(f"u{a.itemsize}"), b.view(f"u{b.itemsize}"))
    )


def field(shape=(9, 10, 11), dtype=np.float32, seed=0):
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    f = np.sin(x * 0.1031 + z * 0.0537 + 0.3) * np.cos(y * 0.0713 - z * 0.0291) * 50
    f += rng.normal(0, 1e-4, shape)
    return f.astype(dtype)


def specials(dtype, shape=(9, 10, 11)):
    """A smooth field holding every kind of special value, and NaN payloads."""
    f = field(shape, dtype)
    flat = f.reshape(-1)
    info = np.finfo(dtype)
    flat[:9] = [
        np.nan,
        -np.nan,
        np.inf,
        -np.inf,
        -0.0,
        0.0,
        info.smallest_subnormal,
        -info.smallest_subnormal,
        -info.tiny,
    ]
    bits = flat.view(f"u{f.itemsize}")
    bits[9] = bits[0] | 1  # NaN payloads, quiet and signalling, either sign
    bits[10] = bits[1] | 0x5
    bits[11] = (bits[0] ^ (1 << (bits.dtype.itemsize * 8 - 2))) | 3
    flat[12], flat[13] = info.max, -info.max
    flat[30:40] = -0.0
    return f


@pytest.mark.parametrize("dtype", DTYPES)
def test_signed_image_matches_naive_and_inverts(dtype):
    a = specials(dtype)
    s = fp.to_signed(a)
    np.testing.assert_array_equal(s, naive.float_signed_image(a))
    assert same_bits(fp.from_signed(s, dtype), a)
    finite = np.array(
        [-np.inf, -1.0, -0.0, 0.0, np.finfo(dtype).smallest_subnormal, 1.0, np.inf], dtype
    )
    assert (np.diff(fp.to_signed(finite)) > 0).all()  # orders like the floats


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize("predictor", fp.PREDICTORS)
def test_lorenzo_residuals_match_naive(dtype, predictor):
    if predictor not in fp.usable(dtype):
        pytest.skip("float16 takes the integer predictors only")
    a = specials(dtype, (5, 6, 7))
    s = fp.to_signed(a).reshape(-1)
    el, rs, state = fp._workspace(s.size)
    si, sf = fp.scratch(a.dtype)
    out = np.empty(s.size * 32 + 1024, dtype=np.uint8)
    n = fp._encode_kernel(
        s,
        a.astype(np.float64).reshape(-1),
        si,
        sf,
        np.array(a.shape, np.int64),
        np.int64(8 * a.itemsize),
        np.int64(predictor),
        out,
        el,
        rs,
        state,
    )
    assert n > 0
    want = naive.float_lorenzo_residuals(
        a, in_slice=predictor in (fp.LORENZO2, fp.LORENZO2F), in_floats=predictor >= fp.LORENZO3F
    )
    np.testing.assert_array_equal(rs.reshape(a.shape), want)


@pytest.mark.parametrize("dtype", DTYPES)
@pytest.mark.parametrize(
    "shape", [(1, 1, 1), (1, 1, 9), (1, 7, 1), (4, 1, 1), (3, 5, 6), (9, 10, 11)]
)
def test_lorenzo_roundtrip_every_shape(dtype, shape):
    a = specials(dtype, (9, 10, 11))[: shape[0], : shape[1], : shape[2]].copy()
    for predictor in fp.usable(dtype):
        assert same_bits(fp.decode_lorenzo(fp.encode_lorenzo(a, predictor), a.shape, a.dtype), a)


@pytest.mark.parametrize("dtype", DTYPES)
def test_extreme_jumps_wrap_exactly(dtype):
    """Neighbours at opposite ends of the bit patterns: residuals wrap and come back."""
    info = np.finfo(dtype)
    rng = np.random.default_rng(3)
    pool = np.array(
        [np.nan, -np.nan, np.inf, -np.inf, info.max, -info.max, 0.0, -0.0, 1.0, -1.0], dtype
    )
    a = rng.choice(pool, (6, 7, 8))
    bits = a.view(f"u{a.itemsize}")
    bits[rng.random(a.shape) < 0.1] = np.iinfo(bits.dtype).max  # the NaN of all ones
    for predictor in fp.usable(dtype):
        assert same_bits(fp.decode_lorenzo(fp.encode_lorenzo(a, predictor), a.shape, a.dtype), a)
    codec = LosslessCodec()
    assert same_bits(codec.decode(codec.encode(a), a.shape, a.dtype), a)


@pytest.mark.parametrize("dtype", DTYPES)
def test_codec_roundtrip_specials_constant_and_noise(dtype):
    codec = LosslessCodec()
    cases = [specials(dtype), np.full((8, 8, 8), -0.0, dtype), np.full((4, 5, 6), np.nan, dtype)]
    rng = np.random.default_rng(7)
    noise = rng.integers(0, 256, (16, 16, 16 * np.dtype(dtype).itemsize), dtype=np.uint8)
    cases.append(noise.view(dtype))  # random bits: NaNs of every payload, denormals
    for a in cases:
        payload = codec.encode(a)
        assert same_bits(codec.decode(payload, a.shape, a.dtype), a)
    # noise: no longer than raw plus the mode byte, and no longer than shuffled zstd
    assert len(payload) <= noise.nbytes + 1
    z = bytes([MODE_ZSTD]) + __import__(
        "volpack.volume_codec.codec", fromlist=["ZstdCodec"]
    ).ZstdCodec(level=19).encode(noise.view(dtype))
    assert len(payload) <= len(z)


@pytest.mark.slow  # float64 encoder signatures no other fast test compiles
def test_float64_volumes_take_the_lossless_codec():
    z, y, x = np.indices((20, 20, 20))
    a = np.sin(x * 0.1031 + z * 0.0537 + 0.3) * np.cos(y * 0.0713 - z * 0.0291) * 50  # smooth
    a.reshape(-1)[:3] = (np.nan, -0.0, 5e-324)
    # version 5: version 6's fitted predictor would compile its float64 kernels (11 CPU s)
    # in the fast set; test_floatfit runs them in the slow set
    blob = api.compress_array(a, brick=10, predict_version=5)
    back = api.decompress_array(blob)
    assert same_bits(back, a)
    with Reader(blob) as r:
        assert r.header["codec"]["id"] == "lossless"
        tools = r.summary.get("tools", {})
    assert any(t.startswith("float-") for t in tools), tools
    assert len(blob) < 0.95 * len(api.compress_array(a, brick=10, codec="zstd"))


def test_smooth_field_beats_every_earlier_tool():
    a = field((32, 32, 32), np.float32)
    v3 = LosslessCodec(predict_version=5).encode(a)  # 6 fits a predictor (test_floatfit)
    v2 = LosslessCodec(predict_version=2).encode(a)
    assert describe(v3) == "float-lorenzo" and len(v3) < 0.97 * len(v2)


# --- lattice ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "dtype", [np.float32, slow_case(np.float64)]
)  # float16 cannot hold tenths of 5000
def test_lattice_found_and_exact(dtype):
    rng = np.random.default_rng(4)
    k = np.cumsum(rng.integers(-40, 41, (12, 13, 14)), axis=2) + 48000
    a = (k * 0.1).astype(dtype)
    found = fp.find_lattices(a)
    # one lattice; one per slice finds the same k and gap under 12 parameter rows, longer
    # whatever codes them, so it is not offered (its integer fields cost a second encode)
    assert len(found) == 1
    assert np.allclose(found[0][0][:, 1], 0.1, rtol=0, atol=1e-9)
    for params, kk, gap in found:
        assert same_bits(fp.apply_lattice(params, kk, gap, dtype), a)
        assert np.count_nonzero(gap) == 0
    codec = LosslessCodec(predict_version=5)  # 6: the fit's float64 kernels, slow set only
    payload = codec.encode(a)
    assert same_bits(codec.decode(payload, a.shape, a.dtype), a)
    assert describe(payload) == "float-lattice"


def test_lattice_off_by_an_ulp_keeps_the_gap():
    a = (np.arange(4 * 5 * 6).reshape(4, 5, 6) * 0.25 + 3.0).astype(np.float32)
    bits = a.reshape(-1).view(np.uint32)
    bits[::7] += 1  # every seventh value one ulp off its lattice point
    params, k, gap = fp.find_lattices(a)[0]
    assert set(np.unique(gap)) <= {0, 1} and np.count_nonzero(gap) == bits[::7].size
    assert same_bits(fp.apply_lattice(params, k, gap, np.float32), a)


def test_lattice_per_slice():
    """GRIB-like packing: each level has its own reference value and binary scale."""
    rng = np.random.default_rng(6)
    k = np.cumsum(rng.integers(-9, 10, (5, 12, 40)), axis=2) + 3000
    ref = rng.uniform(200, 250, (5, 1, 1))
    scale = 2.0 ** rng.integers(-10, -6, (5, 1, 1))
    a = (ref + scale * k).astype(np.float32)
    found = fp.find_lattices(a)
    params, kk, gap = found[-1]
    assert params.shape == (5, 2) and np.count_nonzero(gap) == 0
    assert all(not np.array_equal(kk, other[1]) for other in found[:-1])
    assert same_bits(fp.apply_lattice(params, kk, gap, np.float32), a)
    payload = LosslessCodec().encode(a)
    assert describe(payload) == "float-lattice" and payload[2] == 5  # five lattices
    assert same_bits(LosslessCodec().decode(payload, a.shape, a.dtype), a)
    assert len(payload) < 0.7 * len(bytes([MODE_FLOAT, 0]) + fp.encode_best_lorenzo(a))


def counts_source():
    """scripts/make_examples.py's recipe 'f32-counts', written out again on purpose: a
    density from counts, k * c in float32, and for a third of the voxels the same counts
    through another path that moves the last bits."""
    z, y, x = np.indices((24, 28, 32))
    rate = 2000 * (1.4 + np.sin(x / 5) * np.cos(y / 7) + 0.3 * np.sin(z / 4))
    k = np.rint(rate).astype(np.int64) + (x * 7 + y * 13 + z * 29) % 41 - 20
    c = np.float32(0.000515625)
    f = (k * c).astype(np.float32)
    two = (x + 2 * y + 3 * z) % 3 == 0
    f[two] = k[two].astype(np.float32) / np.float32(1 / c) * np.float32(1.0000019)
    return f


def test_counts_times_a_constant_by_two_paths_find_their_lattice(monkeypatch):
    """The near-equal values made the step estimate rounding noise; the step from the
    values of least magnitude finds the lattice: far shorter, bit for bit, and the
    golden stream of the recipe is reproduced."""
    a = counts_source()
    assert np.unique(a).size > 1.5 * np.unique(np.rint(a / np.float32(0.000515625))).size
    payload = LosslessCodec().encode(a)
    assert describe(payload) == "float-lattice"
    assert same_bits(LosslessCodec().decode(payload, a.shape, a.dtype), a)
    blob = (GOLDEN / "lossless-f32-counts.vpk").read_bytes()
    assert same_bits(api.decompress(blob).data, a)
    monkeypatch.setattr(lossless, "LOWM", False)  # reproduced without LOWM (session 39)
    with Reader(blob) as old, Reader(api.compress_array(a, brick=32)) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
    monkeypatch.setattr(fp, "MAGNITUDE_STEP", False)
    assert 1.5 * len(payload) < len(LosslessCodec().encode(a))


def test_no_lattice_for_noise_or_non_finite():
    rng = np.random.default_rng(1)
    assert fp.find_lattices(rng.normal(size=(8, 8, 8)).astype(np.float32)) == []
    a = (np.arange(512).reshape(8, 8, 8) * 0.5).astype(np.float32)
    a[0, 0, 0] = np.nan
    assert fp.find_lattices(a) == []


def test_no_lattice_as_fine_as_the_floats_themselves():
    """A smooth field in one binade sits on the float spacing itself: k would span as
    many values as the signed images do, so no lattice is offered (coding its two integer
    fields with every integer tool cost most of the encoder's time for nothing)."""
    rng = np.random.default_rng(3)
    a = (1.5 + 0.4 * np.cumsum(rng.normal(size=(6, 20, 24)), axis=2) / 60).astype(np.float32)
    assert 1.0 <= a.min() and a.max() < 2.0  # one binade: its ulps form a lattice
    assert fp.find_lattices(a) == []
    k = a.astype(np.float64) * 2.0**23
    assert np.array_equal(k, np.rint(k))  # ... which the old rule would have taken


# --- per-brick choice, info, versions -----------------------------------------------------


def test_auto_keeps_the_shortest_float_tool_per_brick():
    rng = np.random.default_rng(2)
    a = np.empty((16, 16, 32), np.float32)
    a[:, :, :16] = field((16, 16, 16))
    a[:, :, 16:] = (np.cumsum(rng.integers(-3, 4, (16, 16, 16)), axis=0) * 0.1 + 500).astype(
        np.float32
    )
    blob = api.compress_array(a, brick=16, predict_version=3)
    assert same_bits(api.decompress_array(blob), a)
    with Reader(blob) as r:
        tools = Counter(describe(p) for _, _, p in r)
    assert tools == {"float-lorenzo": 1, "float-lattice": 1}


def test_exact_floats_take_long_bricks_by_default():
    """Exactly coded floats default to 128^3 bricks: zstd then matches across what would be
    64^3 brick edges (here noise repeated along x, which no predictor sees)."""
    noise = np.random.default_rng(5).normal(size=(8, 16, 64)).astype(np.float32)
    a = np.concatenate([noise, noise], axis=2)
    blob = api.compress_array(a)
    assert same_bits(api.decompress_array(blob), a)
    with Reader(blob) as r:
        assert r.header["brick"] == [128, 128, 128]
    assert len(blob) < 0.6 * len(api.compress_array(a, brick=64))
    assert api.info(api.compress_array(a, codec="fast"))["header"]["brick"] == [64, 64, 64]
    ints = api.compress_array(np.zeros((4, 4, 4), np.int16))
    assert api.info(ints)["header"]["brick"] == [128, 128, 128]  # small integer volumes too
    assert bricks.default_brick((129, 128, 128), np.int16, False, "auto") == (64, 64, 64)
    assert bricks.default_brick((4, 4, 4), np.int16, False, "auto", lossy=True) == (64, 64, 64)


def test_version_two_writes_no_float_prediction():
    a = field((16, 16, 16))
    for version in (1, 2):
        assert LosslessCodec(predict_version=version).encode(a)[0] != MODE_FLOAT
    assert LosslessCodec().get_config()["predict_version"] == 8


# --- golden streams ----------------------------------------------------------------------

# The recipes of scripts/make_examples.py, written out again on purpose.
GOLDEN_CASES = [
    ("lossless-v3-f32-special", "f32-special", {"float-lattice", "predict+palette"}),
    ("lossless-v3-f32-smooth", "f32-smooth", {"float-lorenzo"}),
    ("lossless-v3-f64-smooth", "f64-smooth", {"float-lorenzo"}),
    ("lossless-v3-f32-lattice", "f32-lattice", {"float-lattice"}),
    ("lossless-v3-f32-packed", "f32-packed", {"float-lattice"}),
]


def golden_source(recipe):
    from volpack.demo import load_demo_volume

    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    if recipe in ("f32-smooth", "f64-smooth"):
        z, y, x = np.indices((20, 24, 28))
        f = np.sin(x * 0.21 + z * 0.05) * np.cos(y * 0.17) * 80.0 + z * 0.3
        f = f.astype(np.float32 if recipe == "f32-smooth" else np.float64)
        f[3, 4, 5:7] = (np.nan, -0.0)
        f[9, 9, 9] = 5e-324 if recipe == "f64-smooth" else 1e-42
        return f
    if recipe == "f32-packed":
        c = cut.astype(np.float64)
        k = np.cumsum(c - c.mean(), axis=2) * 5
        z = np.arange(c.shape[0]).reshape(-1, 1, 1)
        return (230.0 + 0.37 * z + 2.0 ** -(7 + z % 3) * np.round(k)).astype(np.float32)
    if recipe == "f32-lattice":
        c = cut.astype(np.float64)
        return (np.round(np.cumsum(c - c.mean(), axis=2) * 3 + 50000.0) * 0.1).astype(np.float32)
    return float_specials(cut)


@pytest.mark.parametrize(
    "stem,recipe,tools",
    # float64's kernels compile for this case alone (results/tests/kernel_use35.md): slow set
    [pytest.param(*c, id=c[0], marks=[pytest.mark.slow] if "f64" in c[0] else [])
     for c in GOLDEN_CASES],
)  # fmt: skip
def test_golden_float_prediction_stream(stem, recipe, tools, monkeypatch):
    # made before the lattice step from the values of least magnitude (session 33), which
    # codes two bricks of the special floats 185 bytes shorter; lossless-f32-counts.vpk
    # is a stream of it
    monkeypatch.setattr(fp, "MAGNITUDE_STEP", False)
    blob = (GOLDEN / f"{stem}.vpk").read_bytes()
    want = golden_source(recipe)
    assert same_bits(api.decompress(blob).data, want)
    again = api.compress_array(want, brick=16, predict_version=3)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]
        assert {describe(p) for _, _, p in old} == tools


# --- corrupt payloads --------------------------------------------------------------------


def test_corrupt_float_payloads_raise_format_error():
    codec = LosslessCodec()
    a = field((6, 7, 8))
    lor = bytes([MODE_FLOAT, 0]) + fp.encode_lorenzo(a)
    walk = np.cumsum(np.random.default_rng(8).integers(-30, 31, (6, 7, 8)), axis=2)
    lat_a = (walk * 0.1 + 7).astype(np.float32)
    lat = codec.encode(lat_a)
    assert describe(lat) == "float-lattice"
    bad = [
        bytes([MODE_FLOAT]),  # no tool byte
        bytes([MODE_FLOAT, 3]) + lor[2:],  # unknown tool
        bytes([MODE_FLOAT, 0, 7]) + lor[3:],  # unknown predictor
        bytes([MODE_FLOAT, 0]),  # no predictor byte
        lor[:3],  # no stream
        lor[: len(lor) // 2],  # cut short
        lor + b"\x00\x00",  # does not end where it says
        lat[:10],  # inside offset and step
        lat[:2] + bytes([3]) + lat[3:],  # neither one lattice nor one per slice
        lat[:19] + b"\xff\xff\x03",  # k field longer than the payload
        lat[: len(lat) - 3],  # gap field cut short
    ]
    for data in bad:
        with pytest.raises(FormatError):
            codec.decode(data, a.shape, a.dtype)
    with pytest.raises(FormatError):  # mode 5 means nothing for integers
        codec.decode(lor, a.shape, np.int16)


@pytest.mark.slow  # compiles the float64 encoder and decoder
def test_bit_flips_raise_or_decode():
    codec = LosslessCodec()
    rng = np.random.default_rng(5)
    for a in (specials(np.float32, (6, 7, 8)), specials(np.float64, (6, 7, 8))):
        good = bytes([MODE_FLOAT, 0]) + fp.encode_lorenzo(a)
        flip_bits(codec, good, a, rng, 40)
