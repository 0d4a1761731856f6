"""The fast codec: MED / 3-D MED prediction and static rANS, every dtype and shape, each
predictor and context rule against a plain-Python reference, golden streams and
corrupt payloads."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import benchmark_volume, float_specials, slow_case

from volpack import api
from volpack.entropy import rans
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader
from volpack.volume_codec import fastpredict, palette
from volpack.volume_codec.codec import ZstdCodec
from volpack.volume_codec.fast import (
    FLAG_FLOAT,
    FLAG_PALETTE,
    MODE_CODED,
    MODE_CONSTANT,
    MODE_RAW,
    MODE_ZSTD,
    ZSTD_DENSE,
    ZSTD_SLACK,
    FastCodec,
    describe,
)
from volpack.volume_codec.registry import get_codec

GOLDEN = Path(__file__).resolve().parents[2] / "formats" / "examples"
SHAPES = [(1, 1, 1), (1, 1, 9), (1, 7, 1), (5, 1, 1), (3, 4, 5), (2, 2, 2), (9, 17, 13)]


def smooth(shape, seed=0, noise=2.0):
    rng = np.random.default_rng(seed)
    z, y, x = np.indices(shape)
    return 60 + 40 * np.sin(x / 5.0) * np.cos(y / 7.0) + 3 * z + rng.normal(0, noise, shape)


def same_bits(a, b):
    return a.dtype == b.dtype and np.array_equal(
        a.view(f"u{a.itemsize}"), np.ascontiguousarray(b).view(f"u{a.itemsize}")
    )


# --- the stream: every predictor and context rule ----------------------------------------


def blocks(shape, seed=0):
    """Label-like voxels: a constant background, boxes of other values, a ball (runs
    that cross rows and slices, and end at edges the predictor does or does not get)."""
    rng = np.random.default_rng(seed)
    a = np.zeros(shape, dtype=np.int64)
    for _ in range(4):
        lo = [int(rng.integers(0, max(1, n - 1))) for n in shape]
        hi = [int(rng.integers(a0 + 1, n + 1)) for a0, n in zip(lo, shape)]
        a[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]] = rng.integers(1, 9)
    z, y, x = np.indices(shape)
    c = [n / 2 for n in shape]
    a[(z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2 < (min(shape) / 3) ** 2] = 5
    return a


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("predictor", fastpredict.PREDICTORS)
@pytest.mark.parametrize("context", fastpredict.CONTEXTS)
@pytest.mark.parametrize("runs,rows", [(False, False), (True, False), (True, True)])
def test_stream_roundtrip_every_shape(shape, predictor, context, runs, rows):
    for v in (
        np.rint(smooth(shape)).astype(np.int64),
        np.rint(smooth(shape, noise=40) * 300).astype(np.int64),  # raw low bits
        blocks(shape),
        np.zeros(shape, dtype=np.int64),  # one run to the brick's end
    ):
        lo, hi = int(v.min()), int(v.max())
        data = fastpredict.encode(v, lo, hi, predictor, context, runs, rows)
        assert bool(data[0] & fastpredict.RUNS) == runs
        assert bool(data[0] & fastpredict.ROWS) == rows
        back = fastpredict.decode(data, shape, lo, hi)
        np.testing.assert_array_equal(back, v)


def test_work_arrays_reused_only_when_asked():
    """``decode`` keeps a thread's work arrays between bricks: a reused result is
    overwritten by the next call (of any size), a plain one is the caller's."""
    small, big = blocks((3, 5, 6), 2), blocks((5, 9, 13), 3)
    ds, db = (fastpredict.encode(v, 0, int(v.max())) for v in (small, big))
    kept = fastpredict.decode(ds, small.shape, 0, int(small.max()))
    shared = fastpredict.decode(ds, small.shape, 0, int(small.max()), reuse=True)
    np.testing.assert_array_equal(shared, small)
    again = fastpredict.decode(db, big.shape, 0, int(big.max()), reuse=True)
    np.testing.assert_array_equal(again, big)
    np.testing.assert_array_equal(kept, small)  # not the work array
    again = fastpredict.decode(ds, small.shape, 0, int(small.max()), reuse=True)
    np.testing.assert_array_equal(again, small)


@pytest.mark.parametrize("shape", [(6, 9, 11), (3, 20, 64), (2, 3, 3)])
def test_runs_on_labels_and_background(shape):
    """Long runs: every voxel of a background brick but its first rows and columns is in
    one run; label boxes leave runs that the decoder fills a row segment at a time."""
    for v in (blocks(shape, 1), blocks(shape, 2) * 1000 - 7, np.full(shape, 3, np.int64)):
        v[0, 0, 0] += 1
        lo, hi = int(v.min()), int(v.max())
        for predictor in fastpredict.PREDICTORS:
            for rows in (False, True):
                data = fastpredict.encode(v, lo, hi, predictor, "far", True, rows)
                np.testing.assert_array_equal(fastpredict.decode(data, shape, lo, hi), v)


@pytest.mark.parametrize("context", fastpredict.CONTEXTS)
def test_stream_extreme_range(context):
    rng = np.random.default_rng(3)
    v = rng.integers(-(2**31), 2**31, (6, 7, 8), dtype=np.int64)
    v[0, 0, 0], v[-1, -1, -1] = -(2**31), 2**31 - 1  # residuals of 33 bits
    for predictor in fastpredict.PREDICTORS:
        data = fastpredict.encode(v, -(2**31), 2**31 - 1, predictor, context)
        np.testing.assert_array_equal(fastpredict.decode(data, v.shape, -(2**31), 2**31 - 1), v)


def _reference_tokens(v, lo, hi, pid, cid, runs=False, rows=False):
    """Tokens and contexts of formats/fast-1.md steps 4, 5 (with its runs and rows) and
    7, in plain Python; a run's length in context ``RUN_LENGTH``, the voxel that ends it
    in ``RUN_BREAK``, a row's kind in ``ROW_KIND`` + the kind before, a copy run's
    further rows in ``ROW_COUNT`` + kind - 1."""
    nz, ny, nx = v.shape
    u = np.zeros(v.shape, dtype=np.int64)
    toks, ctxs = [], []
    inrun, length = False, 0
    prev, copies = 0, 0
    rowlist = [(z, y) for z in range(nz) for y in range(ny)]

    def copies_of(k, back):  # rows from row k on equal to the row ``back`` rows before
        c = 0
        while k + c < len(rowlist):
            z, y = rowlist[k + c]
            if back == 1 and y == 0 or back == ny and z == 0:
                break
            if not np.array_equal(v.reshape(-1, nx)[k + c], v.reshape(-1, nx)[k + c - back]):
                break
            c += 1
        return c

    def token(n):
        b = n.bit_length()
        return n if n < 16 else 16 + 4 * (b - 5) + ((n >> (b - 3)) & 3)

    def put(n, c):
        toks.append(token(n))
        ctxs.append(c)

    def med(a, b, c):
        return min(max(a + b - c, min(a, b)), max(a, b))

    def at(z, y, x):
        return lambda dz, dy, dx: int(v[z - dz, y - dy, x + dx])

    for z in range(nz):
        for y in range(ny):
            k = z * ny + y
            if rows and k > 0 and copies == 0:
                n_, u_ = copies_of(k, 1), copies_of(k, ny)
                kind = 1 if n_ else 2 if u_ else 0
                put(kind, fastpredict.ROW_KIND + prev)
                prev = kind
                if kind:
                    copies = n_ if kind == 1 else u_
                    put(copies - 1, fastpredict.ROW_COUNT + kind - 1)
            if copies:
                copies -= 1
                continue  # residuals 0
            for x in range(nx):
                V = at(z, y, x)
                if x > 0 and y > 0:
                    p = med(V(0, 0, -1), V(0, 1, 0), V(0, 1, -1))
                    d = V(1, 0, 0) - med(V(1, 0, -1), V(1, 1, 0), V(1, 1, -1)) if z else 0
                elif x > 0:
                    p, d = V(0, 0, -1), (V(1, 0, 0) - V(1, 0, -1) if z else 0)
                elif y > 0:
                    p, d = V(0, 1, 0), (V(1, 0, 0) - V(1, 1, 0) if z else 0)
                else:
                    p, d = (V(1, 0, 0) if z else (lo + hi) >> 1), 0
                p += (0, d, d >> 1)[pid]
                p = min(max(p, lo), hi)
                a, g = 0, 0
                if y > 0:
                    a += u[z, y - 1, x]
                    if x > 0:
                        a += u[z, y - 1, x - 1]
                        g += abs(V(0, 1, 0) - V(0, 1, -1))
                        if cid == 0:
                            g += abs(V(0, 0, -1) - V(0, 1, -1))
                    if x + 1 < nx:
                        a += u[z, y - 1, x + 1]
                        g += abs(V(0, 1, 1) - V(0, 1, 0))
                if x > 0 and cid == 0:
                    a += u[z, y, x - 1]
                if z > 0:
                    a += u[z - 1, y, x]
                a = int(a + 2 * g)
                n = a.bit_length()
                cls = a if a < 4 else min(47, 2 * n - 2 + ((a >> (n - 2)) & 1))
                e = int(v[z, y, x]) - p
                ue = 2 * e if e >= 0 else -2 * e - 1
                u[z, y, x] = ue
                if not inrun and runs and a == 0 and y > 0 and 0 < x < nx - 1:
                    inrun, length = True, 0
                elif not inrun:
                    put(ue, cls)
                    continue
                if ue == 0:
                    length += 1
                    if rows and x == nx - 1:  # a run stops with its row
                        put(length, fastpredict.RUN_LENGTH)
                        inrun = False
                else:
                    put(length, fastpredict.RUN_LENGTH)
                    put(ue, fastpredict.RUN_BREAK)
                    inrun = False
    if inrun:
        put(length, fastpredict.RUN_LENGTH)
    return toks, ctxs


@pytest.mark.parametrize("pid", range(3))
@pytest.mark.parametrize("cid", range(2))
@pytest.mark.parametrize("runs,rows", [(False, False), (True, False), (True, True)])
def test_tokens_and_contexts_match_the_reference(pid, cid, runs, rows):
    labels = blocks((5, 8, 9), 3)
    labels[2:, 3:6, 2:7] += np.arange(5)  # edges the predictor misses: runs end there
    slab = blocks((6, 9, 8), 4)
    slab[3] = slab[2]  # a slice that copies the one above
    slab[1, 4:] = slab[1, 3]  # rows that copy the row above, to the slice's end
    scan = np.rint(smooth((4, 6, 7), noise=9) * 7).astype(np.int64)
    for v in (scan, labels, slab):
        lo, hi = int(v.min()), int(v.max())
        n = v.size
        toks, ctxs = np.empty(3 * n, np.uint8), np.empty(3 * n, np.uint8)
        counts = np.zeros((fastpredict.ROW_KIND + 5, rans.MAX_SYMBOLS), dtype=np.int64)
        nbits, nsym, covered, copied = fastpredict._tokens_kernel(
            v.reshape(-1), np.array(v.shape, dtype=np.int64), np.int64(lo), np.int64(hi),
            pid, cid, runs, rows, toks, ctxs, np.zeros(2 * v[0].size, np.int64), counts,
            np.empty(4 * n + 16, np.uint8),
        )  # fmt: skip
        want_t, want_c = _reference_tokens(v, lo, hi, pid, cid, runs, rows)
        assert toks[:nsym].tolist() == want_t and ctxs[:nsym].tolist() == want_c
        assert nbits == sum(int(fastpredict.TOK_BITS[t]) for t in want_t)
        assert (fastpredict.RUN_LENGTH in want_c) == (runs and v is not scan)
        if rows and v is slab:  # copies of the row above and of the slice above
            assert {fastpredict.ROW_COUNT, fastpredict.ROW_COUNT + 1} <= set(want_c)


# --- the codec: modes, dtypes, the encoder's choice --------------------------------------


@pytest.mark.parametrize("dtype", ["uint8", "int8", "uint16", "int16", "uint32", "int32"])
def test_codec_roundtrip_integer_dtypes(dtype):
    info = np.iinfo(dtype)
    a = np.clip(np.rint(smooth((7, 9, 11), noise=3)) - 70, info.min, info.max).astype(dtype)
    a.flat[5] = info.min
    a.flat[-3] = info.max  # the whole range: residuals as wide as the dtype
    c = FastCodec()
    p = c.encode(a)
    assert same_bits(a, c.decode(p, a.shape, a.dtype))


def test_codec_codes_a_mask_and_refuses_other_values_for_it():
    """bool bricks coded as 0s and 1s decode (the decoder asked np.iinfo of bool), and
    a coded payload of wider values is refused for bool voxels."""
    z, y, x = np.indices((12, 14, 16))
    mask = (z - 6) ** 2 + (y - 7) ** 2 + (x - 8) ** 2 < 30
    c = FastCodec(zstd=False)
    p = c.encode(mask)
    assert p[0] == MODE_CODED
    assert same_bits(mask, c.decode(p, mask.shape, mask.dtype))
    wide = c.encode(np.rint(smooth((12, 14, 16), noise=3)).astype(np.uint8))
    assert wide[0] == MODE_CODED
    with pytest.raises(FormatError):
        c.decode(wide, mask.shape, mask.dtype)


# float32 compiles a decoder signature no other fast test uses (7 CPU s): slow set
@pytest.mark.parametrize("dtype", ["float16", slow_case("float32")])
def test_codec_floats_bit_exact(dtype):
    a = (smooth((6, 7, 8)) / 7).astype(dtype)
    a[0, 0, :4] = [np.nan, -0.0, np.inf, -np.inf]
    a[1, 1, 1] = np.finfo(dtype).smallest_subnormal
    c = FastCodec()
    assert same_bits(a, c.decode(c.encode(a), a.shape, a.dtype))
    field = (smooth((6, 7, 8), noise=0.01) / 7).astype(dtype)  # coded, not raw
    p = c.encode(field)
    assert p[0] == MODE_CODED and p[1] & FLAG_FLOAT
    assert same_bits(field, c.decode(p, field.shape, field.dtype))


def test_codec_modes_constant_raw_palette():
    c = FastCodec(zstd=False)
    one = np.full((5, 6, 7), -1234, dtype=np.int16)
    assert c.encode(one)[0] == MODE_CONSTANT and len(c.encode(one)) == 3
    noise = np.random.default_rng(1).integers(0, 256, (8, 8, 8)).astype(np.uint8)
    assert c.encode(noise)[0] == MODE_RAW
    sparse = (np.rint(smooth((8, 9, 10))).astype(np.int16) // 4) * 16  # every 16th value
    p = c.encode(sparse)
    assert p[0] == MODE_CODED and p[1] == FLAG_PALETTE
    assert describe(p).endswith("+palette")
    for a in (one, noise, sparse):
        assert same_bits(a, c.decode(c.encode(a), a.shape, a.dtype))


def test_volume_roundtrip_and_info_tools():
    a = np.rint(smooth((40, 37, 70), noise=4) * 20).astype(np.int16)
    blob = api.compress_array(a, codec="fast", brick=32, zstd=True)
    np.testing.assert_array_equal(api.decompress_array(blob, workers=2), a)
    with Reader(blob) as r:
        tools = r.summary["tools"]
        assert r.header["codec"] == {"id": "fast", "runs": True, "rows": True, "zstd": True}
    assert sum(tools.values()) == 2 * 2 * 3
    assert all(t.startswith("fast-") or t == "zstd" for t in tools), tools
    assert get_codec({"id": "fast", "runs": True, "rows": True, "zstd": True}) == FastCodec()
    assert get_codec({"id": "fast", "runs": True, "rows": True}) == FastCodec(zstd=False)
    assert get_codec({"id": "fast", "runs": True}) == FastCodec(rows=False, zstd=False)
    assert get_codec({"id": "fast"}) == FastCodec(runs=False, zstd=False)  # before runs
    assert FastCodec(runs=False).rows is False  # the row kinds go with the run mode
    with pytest.raises(OptionError, match="runs"):
        FastCodec(runs=1)
    with pytest.raises(OptionError, match="rows"):
        FastCodec(rows="yes")
    with pytest.raises(OptionError, match="zstd"):
        FastCodec(zstd=0)
    with pytest.raises(OptionError, match="fast codec"):
        api.compress_array(a, zstd=False)
    with pytest.raises(OptionError, match="fast codec"):
        api.compress_array(a, rows=False)
    with pytest.raises(OptionError, match="fast codec"):
        api.compress_array(a, runs=False)
    with pytest.raises(OptionError, match="fast codec"):
        api.compress_array(a, codec="fast", runs=True, max_error=2)
    labels = blocks((40, 37, 70)).astype(np.uint8)
    blob = api.compress_array(labels, codec="fast", brick=32, zstd=False)
    with Reader(blob) as r:
        assert any("+runs" in t for t in r.summary["tools"]), r.summary["tools"]
        assert any("+rows" in t for t in r.summary["tools"]), r.summary["tools"]
    np.testing.assert_array_equal(api.decompress_array(blob), labels)
    before = api.compress_array(labels, codec="fast", brick=32, rows=False, zstd=False)
    with Reader(before) as r:
        assert r.header["codec"] == {"id": "fast", "runs": True}
        assert not any("+rows" in t for t in r.summary["tools"])
    np.testing.assert_array_equal(api.decompress_array(before), labels)
    old = api.compress_array(labels, codec="fast", brick=32, runs=False, zstd=False)
    with Reader(old) as r:
        assert r.header["codec"] == {"id": "fast"}
        assert not any("+runs" in t for t in r.summary["tools"])
    np.testing.assert_array_equal(api.decompress_array(old), labels)


def test_fast_codec_beats_nothing_but_keeps_most_ratio():
    """A bound: on a smooth noisy field the fast codec stays within 15 % of the default
    codec's size and well below raw."""
    a = np.rint(smooth((32, 32, 32), noise=3)).astype(np.uint8)
    fast = len(api.compress_array(a, codec="fast"))
    default = len(api.compress_array(a))
    assert fast < 0.6 * a.nbytes
    assert fast < 1.15 * default


# --- golden streams ----------------------------------------------------------------------

# The recipes of scripts/make_examples.py, written out again on purpose.
CASES = [
    ("fast-u8", "u8", {"runs": False, "zstd": False}),
    ("fast-u8-background", "u8-background", {"runs": False, "zstd": False}),
    ("fast-i16-palette", "i16", {"runs": False, "zstd": False}),
    ("fast-f32-special", "f32-special", {"runs": False, "zstd": False}),
    ("fast-runs-mixed", "v2-u8-background", {"brick": 16, "rows": False, "zstd": False}),
    ("fast-runs-labels", "labels", {"brick": 32, "rows": False, "zstd": False}),
    ("fast-runs-u8-background", "u8-background", {"brick": 32, "rows": False, "zstd": False}),
    ("fast-rows-labels", "labels-2x", {"brick": 32, "zstd": False}),
    ("fast-rows-mixed", "v2-u8-background", {"brick": 16, "zstd": False}),
    ("fast-zstd-labels", "labels-2x", {"brick": 32}),
    ("fast-zstd-mixed", "v2-u8-background", {"brick": 16}),
]


def golden_source(recipe):
    from volpack.demo import load_demo_volume

    if recipe == "v2-u8-background":
        d = load_demo_volume().data[16:48, 24:56, 24:56].copy()
        d[d < 60] = 0
        return d
    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    if recipe == "u8":
        return cut
    if recipe in ("labels", "labels-2x"):
        lab = np.digitize(cut, [40, 90]).astype(np.uint8)
        lab[:16, :16, :16] = 0
        return lab if recipe == "labels" else np.repeat(np.repeat(lab, 2, axis=0), 2, axis=1)
    if recipe == "u8-background":
        return np.where(cut < 60, 0, cut).astype(np.uint8)
    if recipe == "i16":
        return cut.astype(np.int16) * 37 - 3000
    return float_specials(cut)


@pytest.mark.parametrize("stem,recipe,opts", CASES, ids=[c[0] for c in CASES])
def test_golden_fast_stream(stem, recipe, opts):
    blob = (GOLDEN / f"{stem}.vpk").read_bytes()
    want = golden_source(recipe)
    got = api.decompress(blob).data
    assert same_bits(want, got)
    again = api.compress_array(want, codec="fast", **{"brick": 16, **opts})
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_golden_fast_streams_cover_every_choice():
    seen = set()
    for stem, _, _ in CASES:
        with Reader((GOLDEN / f"{stem}.vpk").read_bytes()) as r:
            for e in r.entries:
                seen.add(describe(r.read(e.t, e.node)).replace("+palette", ""))
    want = {f"fast-{p}-{c}" for p in fastpredict.PREDICTORS for c in fastpredict.CONTEXTS}
    assert want - seen <= {"fast-med3d-near", "fast-med-far"}, seen
    assert {"fast-med-near", "fast-med3d-far", "fast-mean-near", "fast-mean-far"} <= seen
    # the run mode after every predictor
    assert {p + "+runs" for p in ("fast-med-near", "fast-med3d-near", "fast-mean-far")} <= seen
    assert "fast-med3d-near+runs+rows" in seen  # the row kinds
    assert "zstd" in seen  # mode 3


# --- corrupt payloads --------------------------------------------------------------------


def _stream_parts(data):
    """Offsets in a fast stream: after the choice byte and nctx, after the tables, the
    word count's position."""
    data = memoryview(data)
    nctx, pos = palette.read_uleb(data, 1)
    return nctx, pos


def test_corrupt_payloads_raise_format_error():
    c = FastCodec(zstd=False)
    a = np.rint(smooth((6, 7, 8), noise=5) * 9).astype(np.int16)
    good = c.encode(a)
    assert good[0] == MODE_CODED and good[1] == 0
    z, pos = palette.read_uleb(memoryview(good), 2)
    _, pos = palette.read_uleb(memoryview(good), pos)
    head, stream = good[:pos], good[pos:]
    nctx, tpos = _stream_parts(stream)
    bad = [
        b"",
        bytes([4]),  # unknown mode
        bytes([MODE_ZSTD]),  # no frame
        bytes([MODE_ZSTD]) + b"\x28\xb5\x2f\xfd" + bytes(12),  # a broken frame
        bytes([MODE_ZSTD]) + ZstdCodec().encode(a[:-1]),  # a frame of the wrong size
        bytes([MODE_ZSTD]) + ZstdCodec().encode(np.concatenate([a, a])),  # too long
        bytes([MODE_CODED]),  # no flags
        bytes([MODE_CODED, 0x80]) + good[2:],  # unknown flag
        bytes([MODE_CODED, FLAG_FLOAT]) + good[2:],  # float flag on integers
        head,  # no stream
        head + bytes([3]) + stream[1:],  # predictor 3
        head + bytes([stream[0] | 8]) + stream[1:],  # context rule 2
        head + stream[:1] + palette.uleb(0) + stream[tpos:],  # no contexts
        head + stream[:1] + palette.uleb(49) + stream[tpos:],  # too many contexts
        head + stream[:tpos] + palette.uleb(133),  # a table of too many tokens
        head + stream[:tpos] + palette.uleb(1) + palette.uleb(4095),  # sums to 4095
        head + stream[:tpos] + palette.uleb(1) + palette.uleb(4096),  # one token takes all
        good[:-1],  # raw bits cut
        good + b"\0",  # a byte too many
        bytes([MODE_RAW]) + bytes(10),  # raw of the wrong size
        bytes([MODE_CONSTANT]) + bytes(1),
    ]
    bad += [good[:k] for k in range(2, len(good) - 1, max(1, len(good) // 40))]
    for p in bad:
        with pytest.raises(FormatError):
            c.decode(p, a.shape, a.dtype)


def test_a_run_past_the_brick_raises_format_error():
    """A background brick coded as one run: the same stream decoded as a smaller brick
    finds a run longer than the voxels left."""
    v = np.zeros((4, 6, 7), dtype=np.int64)
    v[0, 0, 0] = 1
    data = fastpredict.encode(v, 0, 1, "med", "far", True, False)
    np.testing.assert_array_equal(fastpredict.decode(data, v.shape, 0, 1), v)
    with pytest.raises(FormatError, match="run runs past"):
        fastpredict.decode(data, (3, 6, 7), 0, 1)
    with pytest.raises(FormatError):  # the run mode's flag on a stream without its tables
        plain = fastpredict.encode(v, 0, 1, "med", "far", False)
        fastpredict.decode(bytes([plain[0] | fastpredict.RUNS]) + plain[1:], v.shape, 0, 1)


def test_copied_rows_past_the_brick_raise_format_error():
    """A brick whose rows after the first copy the slice above: one copy run to the
    brick's end, which a smaller brick cannot hold; a row kind that needs a row or slice
    above where there is none; the row kinds' flag without the run mode."""
    v = np.zeros((5, 6, 7), dtype=np.int64)
    v[:, :, 3] = 1
    v[:, 2] = 2
    data = fastpredict.encode(v, 0, 2, "med", "far", True, True)
    np.testing.assert_array_equal(fastpredict.decode(data, v.shape, 0, 2), v)
    with pytest.raises(FormatError, match="copied rows"):
        fastpredict.decode(data, (4, 6, 7), 0, 2)
    flat = np.zeros((3, 4, 5), dtype=np.int64)
    flat[0, 0, 0] = 1
    data = fastpredict.encode(flat, 0, 1, "med", "far", True, True)
    np.testing.assert_array_equal(fastpredict.decode(data, flat.shape, 0, 1), flat)
    with pytest.raises(FormatError):  # one slice of rows: no slice above to copy
        fastpredict.decode(data, (1, 12, 5), 0, 1)
    with pytest.raises(FormatError):
        fastpredict.decode(bytes([data[0] & ~fastpredict.RUNS]) + data[1:], flat.shape, 0, 1)


@pytest.mark.parametrize(
    "name, cut",
    [
        ("liver_labels", np.s_[60:100, 120:190, 130:200]),
        ("frog_labels", np.s_[40:75, 180:250, 150:230]),
    ],
)
def test_rows_round_trip_real_label_maps(name, cut):
    """Cuts of the CGAL liver and the frog segmentation (data cache; skipped without it
    or without its reader): every brick the same with the row kinds forced, left to the
    encoder, and off."""
    a = benchmark_volume(name)
    v = np.ascontiguousarray(a[cut]).astype(np.int64)
    p = palette.build(v)
    ranks = palette.to_ranks(v, p)
    for rows in (True, None, False):
        data = fastpredict.encode(ranks, 0, len(p) - 1, runs=True, rows=rows)
        np.testing.assert_array_equal(fastpredict.decode(data, v.shape, 0, len(p) - 1), ranks)
    blob = api.compress_array(a[cut], codec="fast", brick=32)
    np.testing.assert_array_equal(api.decompress_array(blob, workers=2), a[cut])


def test_damaged_payloads_never_crash():
    """Random byte changes: a FormatError or some array of the right shape and dtype
    (the container's CRC catches the rest), never an out-of-bounds access."""
    rng = np.random.default_rng(7)
    c = FastCodec()
    for a in (
        np.rint(smooth((9, 10, 11), noise=5) * 9).astype(np.int16),
        (np.rint(smooth((9, 10, 11))) // 3 * 5).astype(np.uint8),
        blocks((9, 10, 11)).astype(np.uint8),  # runs
        np.repeat(blocks((5, 10, 11)), 2, axis=0).astype(np.uint8),  # copied rows
    ):
        good = bytearray(c.encode(a))
        for _ in range(150):
            p = bytearray(good)
            for k in rng.integers(0, len(p), rng.integers(1, 4)):
                p[k] = rng.integers(0, 256)
            try:
                out = c.decode(bytes(p), a.shape, a.dtype)
            except FormatError:
                continue
            assert out.shape == a.shape and out.dtype == a.dtype


def test_cli_help_and_compress_fast(tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    r = CliRunner().invoke(main, ["compress", "--help"])
    assert "fast" in r.output and "rANS" in r.output
    src = tmp_path / "v.npy"
    a = np.rint(smooth((20, 21, 22))).astype(np.uint8)
    np.save(src, a)
    out = tmp_path / "v.vpk"
    r = CliRunner().invoke(main, ["compress", str(src), str(out), "--codec", "fast"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["info", str(out)])
    assert "id=fast" in r.output and "fast-" in r.output
    np.testing.assert_array_equal(api.decompress(str(out)).data, a)


def test_activity_table_is_the_class_rule():
    """The decoder looks the class up below 4096; the table must be the rule."""
    for a in range(fastpredict.ACTIVITY.size):
        assert fastpredict.ACTIVITY[a] == fastpredict._activity(a), a


@pytest.mark.parametrize("bits", [20, 23, 24, 26])
def test_residuals_near_the_decoders_cap(bits):
    """The decoder keeps residuals capped at 2^24 for the contexts. Sparse spikes of
    about 2^bits in every other slice over a flat background: the voxels under a spike
    have no gradient, so their class is the spike's residual alone (large, many
    classes of it kept apart by the encoder); they must decode as coded."""
    rng = np.random.default_rng(bits)
    v = np.zeros((8, 24, 24), dtype=np.int64)
    spikes = rng.random(v[::2].shape) < 0.15
    v[::2][spikes] = (1 << bits) - rng.integers(0, 1 << (bits - 2), spikes.sum())
    hi = (1 << bits) - 1
    for predictor in fastpredict.PREDICTORS:
        for context in fastpredict.CONTEXTS:
            data = fastpredict.encode(v, 0, hi, predictor, context, False)
            np.testing.assert_array_equal(fastpredict.decode(data, v.shape, 0, hi), v)


def test_the_cap_keeps_every_class():
    """Why the cap is exact: a sum holding a term of 2^24 or more has class 47 either
    way, and below the cap nothing changes."""
    for terms in ([1 << 24, 0], [(1 << 24) + 5, 3], [1 << 33, 1 << 30], [(1 << 24) - 1, 1]):
        capped = sum(min(t, fastpredict.UCAP) for t in terms)
        assert fastpredict._activity(capped) == fastpredict._activity(sum(terms))


def test_zstd_bricks_where_they_cost_little():
    """Mode 3 is chosen only within its slack of the other payloads (and never longer
    than raw voxels), is exact for every width, and ``zstd=False`` never writes it."""
    rng = np.random.default_rng(3)
    bricks = [
        blocks((24, 24, 24)).astype(np.uint8),
        (blocks((16, 20, 24), seed=1) * 1000 - 3000).astype(np.int16),
        blocks((12, 14, 16), seed=2).astype(np.float32),
        rng.integers(0, 256, (8, 8, 8)).astype(np.uint8),  # noise: raw
    ]
    modes = []
    for a in bricks:
        new, old = FastCodec().encode(a), FastCodec(zstd=False).encode(a)
        assert old[0] != MODE_ZSTD
        modes.append(new[0])
        if new[0] == MODE_ZSTD:
            dense = len(old) * ZSTD_DENSE <= a.nbytes
            assert len(new) <= (1 + ZSTD_SLACK * dense) * len(old) and describe(new) == "zstd"
        else:
            assert new == old
        assert same_bits(a, FastCodec().decode(new, a.shape, a.dtype))
    assert modes[:3].count(MODE_ZSTD) >= 2 and modes[3] == MODE_RAW, modes


def _payloads():
    """One payload of each kind (constant, raw, palette, plain, float) and its brick."""
    c = FastCodec()
    rng = np.random.default_rng(5)
    labels = np.zeros((9, 17, 13), dtype=np.uint8)
    labels[2:7, 3:12, 4:] = 40
    labels[4:, 8:, 6:9] = 200
    out = [
        np.full((4, 5, 6), -7, dtype=np.int16),
        rng.integers(0, 256, (6, 6, 6)).astype(np.uint8),
        labels,
        np.rint(smooth((7, 10, 12))).astype(np.int16),
        (np.rint(smooth((5, 6, 7))) * 1000).astype(np.int32),
        smooth((4, 6, 8)).astype(np.float32),
        np.repeat(labels, 2, axis=1).astype(np.uint16) * 300,  # zstd, two byte planes
    ]
    return [(c.encode(a), a) for a in out]


@pytest.mark.parametrize("k", range(7))
def test_decode_into_a_view_of_a_larger_volume(k):
    """``decode_into`` writes exactly the brick, through any strides, and nothing else."""
    payload, a = _payloads()[k]
    big = np.full((a.shape[0] + 3, a.shape[1] + 4, a.shape[2] + 5), 99, dtype=a.dtype)
    view = big[1 : 1 + a.shape[0], 2 : 2 + a.shape[1], 3 : 3 + a.shape[2]]
    FastCodec().decode_into(payload, view)
    assert same_bits(view.copy(), a)
    rest = np.ones(big.shape, dtype=bool)
    rest[1 : 1 + a.shape[0], 2 : 2 + a.shape[1], 3 : 3 + a.shape[2]] = False
    assert (big[rest] == 99).all()
    assert same_bits(FastCodec().decode(payload, a.shape, a.dtype), a)


@pytest.mark.parametrize("workers", [1, 2])
def test_volume_and_region_decode_in_place(workers):
    """Whole bricks go straight into the volume, bricks cut by a region through a copy:
    both as the array, with one worker or two."""
    a = np.rint(smooth((40, 37, 70), noise=1.0)).astype(np.int16)
    a[:, :10] = 0
    blob = api.compress_array(a, codec="fast", brick=16)
    np.testing.assert_array_equal(api.decompress_array(blob, workers=workers), a)
    vol = api.decompress(blob, roi="3:35,5:30,17:66", workers=workers)
    np.testing.assert_array_equal(vol.data, a[3:35, 5:30, 17:66])
