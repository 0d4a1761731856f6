"""The bounded codec's interpolation path: the walk against a naive reference, the bound
on every voxel, special values, edge bounds, the rANS coder, and damaged payloads."""

from __future__ import annotations

import numpy as np
import pytest
from naive import interp_walk
from test_bounded_cdf97 import check_bound, flags_of

from volpack import api
from volpack.entropy import rans
from volpack.errors import FormatError
from volpack.format.sections import put_section, take_section
from volpack.volume_codec import bounded_interp as bi
from volpack.volume_codec.lossy import FLAG_INTERP, BoundedCodec


def walk_field(dtype=np.float32):
    """A field the interpolation path codes shortest at 1e-3 and 1e-4 of its range: the
    demo MRI summed along z (each slice the previous plus an image)."""
    from volpack.demo import load_demo_volume

    c = load_demo_volume().data[20:40, 30:60, 30:70].astype(np.float64)
    return (np.cumsum(c - c.mean(), axis=0) / 40).astype(dtype)


def rough_float(shape, dtype=np.float32, seed=0):
    """Smooth plus strong noise."""
    r = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(0, 3, n) for n in shape), indexing="ij")
    return (np.sin(z + y) * np.cos(x) * 3 + r.normal(0, 0.3, shape)).astype(dtype)


def wavelet_only(codec, q, best=None):
    """The quantised voxels' codings left to the lossless wavelet alone."""
    from volpack.volume_codec import lossy

    return [(lossy.TIER_MID, codec._inner().encode(q))]


def zigzag(b):
    return np.where(b >= 0, 2 * b, -2 * b - 1)


@pytest.mark.parametrize("kind", [0, 1, 2, 3])
@pytest.mark.parametrize("shape", [(7, 9, 13), (1, 5, 17), (6, 1, 1), (2, 2, 2)])
def test_walk_matches_the_naive_reference_bit_for_bit(kind, shape):
    g = rough_float(shape, np.float64, seed=kind) * 10
    for perm in ((0, 1, 2), (2, 0, 1)):
        rec, sym, ctx, raw, _, _ = bi._run(g, 0.05, perm, kind)
        want, bins, contexts = interp_walk(np.ascontiguousarray(g.transpose(perm)), 0.05, kind)
        np.testing.assert_array_equal(rec, want.transpose(np.argsort(perm)))
        big = zigzag(bins) >= bi.DIRECT
        np.testing.assert_array_equal(sym[~big], zigzag(bins)[~big])
        np.testing.assert_array_equal(ctx, contexts)
        assert big.any() == (raw.size > 0)
        assert np.abs(rec - g).max() <= 0.025 * (1 + 1e-12)


FLAG_OF = {"static": 0, "adaptive": bi.ADAPTIVE, "grouped": bi.GROUPED}


@pytest.mark.parametrize("kind", [0, 1, 2, 3])
@pytest.mark.parametrize("coding", bi.CODINGS_FAST)
def test_every_kind_round_trips_through_its_section(kind, coding):
    g = rough_float((11, 14, 19), np.float64, seed=3)  # 2926 voxels: a partial last group
    flag = FLAG_OF[coding]
    for step in (2.0, 0.02, 1e-7):  # the last: many bins past 32, raw bits
        inner, rec = bi.encode(g, step, tried=((kind, ((1, 2, 0),)),), codings=(coding,))
        assert inner[:3] == bytes([1, 2, 0])  # static: its tables shared or not
        assert inner[3] in ({kind, kind | bi.SHARED} if coding == "static" else {kind | flag})
        np.testing.assert_array_equal(bi.decode(inner, g.shape, step), rec)
        assert np.abs(rec - g).max() <= step / 2 * (1 + 1e-9)
    if coding == "adaptive":  # the bins and contexts it codes: the spec's, naively
        _, bins, _, contexts = interp_walk(
            np.ascontiguousarray(g.transpose(1, 2, 0)), 0.02, kind, adaptive=True
        )
        _, _, _, _, abin, adx = bi._run(g, 0.02, (1, 2, 0), kind)
        np.testing.assert_array_equal(abin, bins)
        np.testing.assert_array_equal(adx, contexts)


@pytest.mark.parametrize("rel", [1e-3, 1e-4])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_such_fields_take_the_interpolation_path_and_hold_the_bound(rel, dtype, monkeypatch):
    # the field sits on a grid of 1/40 with an offset per z slice, which the exact path
    # (the lossless codec) codes shorter in float32 at 1e-4: left out here
    from volpack.volume_codec import lossy

    monkeypatch.setattr(lossy, "_exact_may_pay", lambda x, e: False)
    monkeypatch.setattr(lossy, "EXACT_PROXY", 0.0)
    # and its quantised voxels are coded shorter by the lossless codec's fitted
    # predictor since the quantised-voxel path uses it: that path left to the wavelet
    monkeypatch.setattr(lossy.BoundedCodec, "_code_quantised", wavelet_only)
    # and, since the long fit tries its shortest reach too, that codes it shorter at
    # 1e-3 and 1e-4: left out as well (its own tests are in test_bounded_longfit.py)
    monkeypatch.setattr(lossy.BoundedCodec, "_longfit", lambda codec, q, best: [])
    a = walk_field(dtype)
    e = float(a.max() - a.min()) * rel
    blob = api.compress_array(a, max_error=e)
    assert all(f & FLAG_INTERP for f in flags_of(blob))
    check_bound(a, blob, e)


def test_nan_inf_and_fill_are_restored_exactly_on_the_interpolation_path(monkeypatch):
    from volpack.volume_codec import lossy

    monkeypatch.setattr(lossy.BoundedCodec, "_code_quantised", wavelet_only)
    a = walk_field()
    a[2, 3:9, 4] = np.nan
    a[7, 7, 7] = np.inf
    a[8, 0, 0] = -np.inf
    a[10:12, :, 20:] = -999.0
    e = float(np.ptp(a[np.isfinite(a) & (a > -999)])) * 1e-3
    blob = api.compress_array(a, max_error=e, fill_value=-999.0)
    assert all(f & FLAG_INTERP and f & 1 for f in flags_of(blob))
    check_bound(a, blob, e)


def test_bounds_below_the_float_spacing_and_a_spike_and_a_constant():
    a = rough_float((10, 12, 14)) + 1000  # spacing 6e-5 at 1000
    for e in (1e-7, 1e-3):
        check_bound(a, api.compress_array(a, max_error=e), e)
    b = rough_float((16, 16, 16), np.float64)
    b[8, 8, 8] = 1e6  # a spike far outside the rest
    check_bound(b, api.compress_array(b, max_error=0.01), 0.01)
    c = np.full((9, 9, 9), 3.25, np.float32)
    np.testing.assert_array_equal(api.decompress_array(api.compress_array(c, max_error=0.1)), c)


def test_rans_tables_normalise_and_round_trip():
    counts = np.array([[5, 0, 1, 1000], [0, 0, 0, 0], [0, 7, 0, 0]])
    f = rans.normalise(counts)
    assert list(f.sum(axis=1)) == [rans.TOTAL, 0, rans.TOTAL]
    assert f[0, 2] >= 1 and f[0, 1] == 0 and f[2].max() < rans.TOTAL
    body = rans.pack_tables(f)
    table, used = rans.unpack_tables(body, 3, 4, "t")
    assert used == len(body)
    np.testing.assert_array_equal(table, rans.slot_table(f))
    bad = bytearray(body)
    bad[2] += 1  # first frequency one more: the row no longer sums to TOTAL
    with pytest.raises(FormatError):
        rans.unpack_tables(bytes(bad), 3, 4, "t")
    with pytest.raises(FormatError):
        rans.unpack_tables(body[:-1], 3, 4, "t")


def grouped_tokens(sym):
    """The grouped coding's tokens and contexts of the walk's symbols, by the spec
    (``formats/lossy-1.md`` step 17) in plain Python."""
    toks, ctxs, prev = [], [], 0
    for g in range(0, len(sym), 16):
        group = [int(u) for u in sym[g : g + 16]]
        c = 0
        for u in group:
            c = max(c, u.bit_length())
        toks.append(c)
        ctxs.append(prev)
        prev = c
        if c:
            per = {1: 4, 2: 2, 3: 2}.get(c, 1)
            for j in range(0, len(group), per):
                toks.append(sum(u << (c * i) for i, u in enumerate(group[j : j + per])))
                ctxs.append(7 + c)
    return toks, ctxs


@pytest.mark.parametrize("step", [2.0, 0.05, 1e-6])  # mostly zeros .. every class, raw bits
def test_grouped_tokens_are_the_specs_and_the_bins_come_back(step):
    g = rough_float((9, 13, 21), np.float64, seed=5) * 4  # 2457 voxels: not a multiple of 16
    _, sym, _, _, _, _ = bi._run(g, step, (0, 1, 2), 1)
    want, ctxs = grouped_tokens(sym)
    toks = np.empty(sym.size + sym.size // 16 + 1, np.int64)
    ctx = np.empty_like(toks)
    n = bi._group_tokens(sym, sym.size, toks, ctx)
    assert toks[:n].tolist() == want and ctx[:n].tolist() == ctxs
    assert max(want) < bi.N_SYM and max(ctxs) < bi.N_GROUP_CTX
    if step == 2.0:
        assert want.count(0) > len(sym) // 64  # whole groups of zeros: a token each
    inner, rec = bi.encode(g, step, ((1, ((0, 1, 2),)),), ("grouped",))
    assert inner[3] == 1 | bi.GROUPED
    np.testing.assert_array_equal(bi.decode(inner, g.shape, step), rec)  # bit for bit
    assert np.abs(rec - g).max() <= step / 2 * (1 + 1e-9)


def _interp_payload():
    """A bounded payload of the interpolation path alone (the flag byte and the inner
    section: effort 'fast' may code the quantised voxels instead), every voxel of the
    cast reconstruction within the bound, so no corrections."""
    a = walk_field()
    codec = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), 0.05, effort="fast")
    inner, rec = bi.encode(a.astype(np.float64), codec.step, bi.TRIED_FAST)
    assert np.abs(rec.astype(a.dtype).astype(np.float64) - a).max() <= 0.05
    return a, codec, bytes([FLAG_INTERP]) + put_section(inner)


@pytest.mark.parametrize("coding", bi.CODINGS_FAST)
def test_damaged_interpolation_payloads_raise_format_errors(coding, monkeypatch):
    import functools

    monkeypatch.setattr(bi, "encode", functools.partial(bi.encode, codings=(coding,)))
    a, codec, payload = _interp_payload()
    np.testing.assert_allclose(codec.decode(payload, a.shape, a.dtype), a, rtol=0, atol=0.05)
    inner, _ = take_section(memoryview(payload), 1, "inner")
    start = len(payload) - len(inner)  # where the inner section begins
    cases = [
        payload[:-1],  # cut short
        payload[:start] + bytes([1, 1, 2]) + payload[start + 3 :],  # not a permutation
        payload[: start + 3] + bytes([4]) + payload[start + 4 :],  # unknown kind
        payload[: start + 3] + bytes([20]) + payload[start + 4 :],  # and adaptive
        payload[: start + 3] + bytes([36]) + payload[start + 4 :],  # and grouped
        payload[: start + 3] + bytes([49]) + payload[start + 4 :],  # adaptive and grouped
        bytes([payload[0] | 16]) + payload[1:],  # with the float wavelet's flag
    ]
    r = np.random.default_rng(1)
    for _ in range(40):  # bytes of the stream changed
        b = bytearray(payload)
        i = int(r.integers(start + 4, len(payload)))
        b[i] ^= 1 << int(r.integers(8))
        cases.append(bytes(b))
    raised = 0
    for bad in cases:
        try:
            out = codec.decode(bad, a.shape, a.dtype)
        except FormatError:
            raised += 1
            continue
        assert out.shape == a.shape  # a change the checks cannot see still decodes safely
    assert raised >= len(cases) - 8


def test_the_interpolation_path_refuses_integer_dtypes():
    a, codec, payload = _interp_payload()
    with pytest.raises(FormatError):
        codec.decode(payload, a.shape, np.int32)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_transposed_walk_is_cast_straight_into_the_volume(dtype):
    # the walk's array in axis order (2, 0, 1): its voxels reach a view of a larger
    # volume in one pass, equal to numpy's clip, cast and C-order copy of the walk
    from volpack.format.sections import put_section

    g = rough_float((6, 7, 9), np.float64, seed=5) * 1e3
    inner, _ = bi.encode(g, 0.5, tried=((1, ((2, 0, 1),)),))
    codec = BoundedCodec(max_error=0.25, lo=-4e3, step=0.5, integer=False, qdtype="int32")
    payload = bytes([FLAG_INTERP]) + put_section(inner)
    rec = bi.decode(inner, g.shape, codec.step)
    assert not rec.flags.c_contiguous
    want = rec.astype(dtype, order="C")
    got = codec.decode(payload, g.shape, dtype)
    assert got.flags.c_contiguous
    np.testing.assert_array_equal(got, want)
    vol = np.zeros((8, 7, 11), dtype)
    codec.decode_into(payload, vol[1:7, :, 2:])
    np.testing.assert_array_equal(vol[1:7, :, 2:], want)
    assert not vol[0].any() and not vol[:, :, :2].any()


def test_the_one_pass_cast_of_a_strided_view_clips_as_numpy_does():
    from volpack.volume_codec.floatcast import to_float32

    v = rough_float((5, 6, 7), np.float64, seed=6) * 1e38
    v[0, 1, 2], v[1, 2, 3], v[2, 3, 4] = 1e39, -1e300, np.nan
    for view in (v.transpose(2, 0, 1), v[::2, 1:, ::-1]):
        big = float(np.finfo(np.float32).max)
        want = np.clip(view, -big, big).astype(np.float32)
        np.testing.assert_array_equal(to_float32(view), want)


def test_dequantise_and_scale_match_numpy():
    """The one-pass dequantisation (into a strided view too) and the in-place scaling give
    numpy's values bit for bit, clipping to float32's range included."""
    from volpack.volume_codec.floatcast import dequantise_float32, scale_in_place, to_float32

    rng = np.random.default_rng(3)
    q = rng.integers(0, 2**16, size=(3, 4, 5)).astype(np.uint16)
    for step, lo in ((2.0e-3, -1.7), (1.0e36, -3.0e38)):  # the second passes +-big
        want = to_float32(q.astype(np.float64) * step + lo)
        np.testing.assert_array_equal(dequantise_float32(q, step, lo), want)
        big = np.zeros((3, 5, 5), np.float32)
        dequantise_float32(q, step, lo, big[:, 1:, :])
        np.testing.assert_array_equal(big[:, 1:, :], want)
        assert not big[:, 0, :].any()
    c = rng.integers(-(2**40), 2**40, size=(2, 3, 4))
    np.testing.assert_array_equal(scale_in_place(c.copy(), 0.37), c * 0.37)


def test_rans_tables_kernel_matches_the_plain_reading():
    """The kernel that reads the tables against tests/naive.py's row-by-row reading, on
    valid tables and on thousands of damaged ones (cut, a byte changed, a length raised)."""
    import naive

    rng = np.random.default_rng(24)
    errors = {"cut": "cut short", "past": "runs past", "sum": "sums to"}
    seen = set()
    for trial in range(3000):
        nctx, nsym = int(rng.integers(1, 6)), int(rng.integers(2, 9))
        counts = rng.integers(0, 50, (nctx, nsym)) * (rng.random((nctx, 1)) < 0.8)
        body = bytearray(rans.pack_tables(rans.normalise(counts)))
        if trial % 3 == 1 and len(body):
            body[int(rng.integers(len(body)))] ^= 1 << int(rng.integers(8))
        elif trial % 3 == 2:
            body = body[: int(rng.integers(len(body) + 1))]
        body = bytes(body)
        want = naive.rans_read_tables(body, nctx, nsym)
        if isinstance(want, str):
            seen.add(want)
            with pytest.raises(FormatError, match=errors[want]):
                rans.unpack_tables(body, nctx, nsym, "t")
            continue
        seen.add("ok")
        table, used = rans.unpack_tables(body, nctx, nsym, "t")
        assert used == want[1]
        np.testing.assert_array_equal(table, rans.slot_table(np.array(want[0], np.int64)))
    assert seen == {"ok", "cut", "past", "sum"}


@pytest.mark.parametrize("qdtype", [np.uint8, np.uint16, np.int32])
def test_flat_and_strided_dequantisation_match_the_plain_reading(qdtype):
    """The flat kernels (both arrays C-contiguous) and the 3-D ones (a brick of a larger
    volume) give tests/naive.py's voxel-by-voxel step 3, float32 clipping and integer
    clipping included, from any integer work type."""
    import naive

    from volpack.volume_codec.floatcast import dequantise_float32, dequantise_integer

    rng = np.random.default_rng(26)
    top = min(int(np.iinfo(qdtype).max), 70000)
    q = rng.integers(0, top + 1, size=(4, 5, 7)).astype(qdtype)
    for step, lo in ((2.0e-3, -1.7), (0.2238, 191.8859100341797), (1.0e36, -3.0e38)):
        want = naive.bounded_reconstruct(q, lo, step, np.float32)
        np.testing.assert_array_equal(dequantise_float32(q, step, lo), want)
        big = np.zeros((4, 6, 7), np.float32)
        dequantise_float32(q, step, lo, big[:, 1:, :])
        np.testing.assert_array_equal(big[:, 1:, :], want)
        assert not big[:, 0, :].any()
    for dtype, step, lo in ((np.int16, 7, -300), (np.uint8, 3, 2), (np.int32, 40001, -(2**31))):
        want = naive.bounded_reconstruct(q, lo, step, dtype)
        np.testing.assert_array_equal(dequantise_integer(q, step, lo, dtype), want)
        big = np.zeros((4, 5, 9), dtype)
        dequantise_integer(q, step, lo, dtype, big[:, :, 2:])
        np.testing.assert_array_equal(big[:, :, 2:], want)
        assert not big[:, :, :2].any()


def trilinear_up(shape=(5, 6, 7), up=8, seed=35):
    """A random grid interpolated trilinearly up ``up`` times: between its nodes every
    linear prediction is exact, so nearly every bin is 0."""
    out = np.random.default_rng(seed).normal(size=shape)
    for ax in range(3):
        m = out.shape[ax]
        t = np.arange((m - 1) * up + 1) / up
        i0 = np.minimum(t.astype(int), m - 2)
        f = (t - i0).reshape([-1 if a == ax else 1 for a in range(3)])
        out = np.take(out, i0, axis=ax) * (1 - f) + np.take(out, i0 + 1, axis=ax) * f
    return out * 4 + 20


def test_static_bins_share_tables_where_their_contexts_are_nearly_all_zero(monkeypatch):
    """Session 35: on a field interpolated trilinearly up, 18 tables cost more than their
    contexts save; the shared tables (kind bit 6) code shorter and decode to the same
    voxels, and the encoder keeps 18 tables where they are shorter."""
    g = trilinear_up()
    tried = ((0, ((0, 1, 2),)),)
    plain, rec0 = None, None
    for on in (False, True):
        monkeypatch.setattr(bi, "SHARED_TABLES", on)
        inner, rec = bi.encode(g, 0.4, tried=tried, codings=("static",))
        np.testing.assert_array_equal(bi.decode(inner, g.shape, 0.4), rec)
        if not on:
            plain, rec0 = inner, rec
    assert plain[3] == 0 and inner[3] == bi.SHARED
    assert len(inner) < 0.8 * len(plain)  # 333 against 439 bytes
    np.testing.assert_array_equal(rec, rec0)  # the same walk, only the tables differ
    # where sharing codes longer (here: every context forced into one table, on a field
    # half noise, half a smooth wave) the 18 tables are kept
    monkeypatch.setattr(bi, "share_tables", lambda c: np.zeros(len(c), np.uint8))
    half = rough_float((11, 14, 19), np.float64, seed=3)
    half[:, :, 10:] = np.sin(np.arange(9) / 5)
    inner, _ = bi.encode(half, 0.02, tried=tried, codings=("static",))
    assert inner[3] == 0


def test_share_tables_merges_what_saves_bits():
    counts = np.zeros((bi.N_CTX, bi.N_SYM), np.int64)
    counts[0, :2] = (100000, 3)  # nearly all zeros, and two more such contexts
    counts[3, :3] = (2000, 2, 1)
    counts[6, :2] = (4000, 1)
    counts[9, :40] = 50  # broad and well filled: its own table
    counts[12, 30:70] = 60  # broad elsewhere: its own
    table_of = bi.share_tables(counts)
    assert table_of[0] == table_of[3] == table_of[6]
    assert len({table_of[0], table_of[9], table_of[12]}) == 3
    assert table_of.max() == 2 and table_of[0] == 0  # numbered by first context


def test_damaged_shared_tables_raise_format_errors():
    import zstandard

    g = trilinear_up()
    inner, _ = bi.encode(g, 0.4, tried=((0, ((0, 1, 2),)),), codings=("static",))
    assert inner[3] == bi.SHARED
    body, pos = take_section(inner, 4, "tables")
    tables = zstandard.ZstdDecompressor().decompress(bytes(body))
    k = tables[0]

    def with_tables(t):
        return inner[:4] + put_section(zstandard.ZstdCompressor().compress(t)) + inner[pos:]

    for bad, match in [
        (bytes([0]) + tables[1:], "header"),  # no table
        (bytes([19]) + tables[1:], "header"),  # more than the contexts
        (tables[:10], "header"),  # cut inside the context indices
        (tables[:1] + bytes([k]) + tables[2:], "names table"),  # an index past K
        (bytes([k + 1]) + tables[1:], "cut short"),  # one table fewer than K
        (tables + b"\x00\x00", "stray bytes"),
    ]:
        with pytest.raises(FormatError, match=match):
            bi.decode(with_tables(bad), g.shape, 0.4)
    for kind in (bi.SHARED | bi.ADAPTIVE, bi.SHARED | bi.GROUPED):
        with pytest.raises(FormatError, match="not one of the known"):
            bi.decode(inner[:3] + bytes([kind]) + inner[4:], g.shape, 0.4)
