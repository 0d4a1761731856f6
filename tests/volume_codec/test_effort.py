"""effort='fast' for error-bounded coding: one coding per brick (floats: the
interpolation path), the bound still held on every voxel, the choice kept out of the
header unless asked for, and refused where it has no meaning."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import slow_case, smooth_volume

from volpack import api
from volpack.cli import main
from volpack.errors import FormatError, OptionError
from volpack.format.container import Reader
from volpack.format.sections import take_section
from volpack.volume_codec import bounded_interp
from volpack.volume_codec.lossy import (
    FAST_ADAPTIVE_OVER_GROUPED,
    FAST_ADAPTIVE_SAVING,
    FLAG_INTERP,
    QVOX_FAST,
    BoundedCodec,
)


def smooth_float(shape, dtype, seed=3):
    f = smooth_volume(shape, np.int16, seed=seed).astype(np.float64) / 7.0
    return f.astype(dtype)


def header_codec(blob: bytes) -> dict:
    with Reader(blob) as r:
        return dict(r.header["codec"])


def payload_flags(blob: bytes) -> list[int]:
    with Reader(blob) as r:
        return [r.read(e.t, e.node)[0] for e in r.entries]


@pytest.mark.parametrize("dtype", [np.float32, slow_case(np.float64)])  # float64: slow set
@pytest.mark.parametrize("rel", [1e-2, 1e-4])
def test_fast_holds_the_bound_on_every_voxel_with_specials(dtype, rel):
    a = smooth_float((20, 26, 31), dtype)
    a[3, 4, 5], a[7, 0, 0], a[-1, -1, -1] = np.nan, np.inf, -np.inf
    a[10:12, 10:14, :] = -9999.0
    e = float(np.nanmax(a[np.isfinite(a)]) - np.nanmin(a[np.isfinite(a)])) * rel
    blob = api.compress_array(a, max_error=e, fill_value=-9999.0, effort="fast")
    back = api.decompress_array(blob)
    special = ~np.isfinite(a) | (a == -9999.0)
    assert np.array_equal(back[special], a[special], equal_nan=True)
    err = np.abs(back[~special].astype(np.float64) - a[~special].astype(np.float64))
    assert err.max() <= e
    assert header_codec(blob)["effort"] == "fast"
    # every float brick takes the interpolation path (flag byte of the payload) or its
    # quantised voxels go to the fast codec (inner byte 6)
    with Reader(blob) as r:
        assert all(p[0] & FLAG_INTERP or p[5] == QVOX_FAST for _, _, p in r)


def test_default_keeps_its_bytes_and_leaves_effort_out_of_the_header():
    a = smooth_float((24, 24, 24), np.float32)
    e = float(np.ptp(a)) * 1e-3
    implicit = api.compress_array(a, max_error=e)
    explicit = api.compress_array(a, max_error=e, effort="default")
    assert implicit == explicit
    assert "effort" not in header_codec(implicit)


@pytest.mark.parametrize("dtype", [np.float32, np.int16])  # interpolation / fast codec
def test_fast_is_the_same_bytes_for_any_worker_count(dtype):
    a = smooth_float((40, 36, 30), np.float32)
    if dtype == np.int16:
        a = (a * 9).astype(np.int16)
    e = float(np.ptp(a)) * 1e-3
    one = api.compress_array(a, max_error=e, effort="fast", brick=16, workers=1)
    two = api.compress_array(a, max_error=e, effort="fast", brick=16, workers=2)
    assert one == two


def test_fast_grouped_bins_are_the_same_bytes_for_any_worker_count():
    a = smooth_float((40, 36, 30), np.float32)
    a += np.random.default_rng(2).normal(0, 1.0, a.shape).astype(np.float32)
    e = float(np.ptp(a)) * 1e-2
    one = api.compress_array(a, max_error=e, effort="fast", brick=24, workers=1)
    two = api.compress_array(a, max_error=e, effort="fast", brick=24, workers=2)
    assert one == two
    with Reader(one) as r:  # eight bricks: two grouped, the rest by the fast codec
        kinds = [take_section(memoryview(p), 1, "inner")[0][3] for _, _, p in r if p[0] & 64]
    assert any(k & bounded_interp.GROUPED for k in kinds)
    back = api.decompress_array(one, workers=2)
    assert np.abs(back.astype(np.float64) - a).max() <= e


def test_fast_on_integers_codes_the_quantised_voxels_within_the_bound():
    a = smooth_volume((20, 24, 28), np.int16, seed=5)
    blob = api.compress_array(a, max_error=3, effort="fast")
    back = api.decompress_array(blob)
    assert np.abs(back.astype(np.int64) - a).max() <= 3


def test_fast_psnr_target_on_floats():
    a = smooth_float((24, 24, 24), np.float32)
    blob = api.compress_array(a, psnr=60.0, effort="fast")
    back = api.decompress_array(blob).astype(np.float64)
    mse = float(np.mean((back - a) ** 2))
    psnr = 10 * np.log10(float(np.ptp(a)) ** 2 / mse)
    assert abs(psnr - 60.0) <= 0.5 or psnr > 60.0


@pytest.mark.parametrize(
    "kw, found",
    [
        ({}, "for a faster lossless stream use codec='fast'"),
        ({"quality": 63}, "found quality=63"),
        ({"max_error": 1.0, "wavelet": "cdf97"}, "with wavelet='cdf97'"),
    ],
)
def test_fast_is_refused_where_it_has_no_meaning(kw, found):
    a = smooth_volume((16, 16, 16), np.int16, seed=1)
    if "wavelet" in kw:
        a = a.astype(np.float32)
    with pytest.raises(OptionError, match="effort='fast' applies to error-bounded"):
        try:
            api.compress_array(a, effort="fast", **kw)
        except OptionError as err:
            assert found in str(err)
            raise


def test_unknown_effort_is_a_clear_error():
    a = smooth_float((8, 8, 8), np.float32)
    with pytest.raises(OptionError, match="effort"):
        api.compress_array(a, max_error=0.1, effort="best")


def test_cli_effort(tmp_path):
    a = smooth_float((16, 20, 24), np.float32)
    src = tmp_path / "f.npy"
    np.save(src, a)
    out = tmp_path / "f.vpk"
    r = CliRunner().invoke(
        main, ["compress", str(src), str(out), "--rel-error", "1e-3", "--effort", "fast", "--json"]
    )
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["ratio"] > 1
    assert header_codec(out.read_bytes())["effort"] == "fast"
    r = CliRunner().invoke(
        main, ["compress", str(src), str(tmp_path / "o.vpk"), "--octree", "--effort", "fast"]
    )
    assert r.exit_code == 2 and "--effort applies to a volume" in r.output
    r = CliRunner().invoke(main, ["compress", str(src), str(out), "--effort", "slow"])
    assert r.exit_code == 2 and "slow" in r.output


def test_cli_effort_max_is_lossless_version_10(tmp_path):
    v = np.clip(smooth_float((12, 16, 18), np.float32) * 20 + 100, 0, 255).astype(np.uint8)
    src = tmp_path / "v.npy"
    np.save(src, v)
    out = tmp_path / "v.vpk"
    r = CliRunner().invoke(main, ["compress", str(src), str(out), "--effort", "max", "--json"])
    assert r.exit_code == 0, r.output
    assert header_codec(out.read_bytes())["predict_version"] == 10
    assert api.decompress(out.read_bytes()).data.tobytes() == v.tobytes()
    w = tmp_path / "w.vpk"
    r = CliRunner().invoke(main, ["compress", str(src), str(w), "--effort", "max", "--max-error", "1"])
    assert r.exit_code == 0, r.output
    assert header_codec(w.read_bytes())["effort"] == "max"


@pytest.mark.slow  # the local fit's decoder: a kernel only these tests compile (kernel_use36.md)
def test_effort_max_under_a_bound_is_the_shortest_within_it():
    """'max' keeps the shortest coding whatever its decoding tier, and codes the quantised
    voxels with the lossless codec's local fit: its bricks never longer (its header says
    effort 'max'), every voxel in bound."""

    def payload(blob):
        with Reader(blob) as r:
            return sum(len(p) for _, _, p in r)

    a = smooth_float((24, 28, 30), np.float32, seed=4)
    e = 1e-3 * float(a.max() - a.min())
    for kw in ({"max_error": e}, {"max_error": e / 30}):
        d = api.compress_array(a, **kw)
        m = api.compress_array(a, effort="max", **kw)
        assert payload(m) <= payload(d)
        back = api.decompress_array(m)
        assert np.abs(back.astype(np.float64) - a).max() <= kw["max_error"]
    v = np.clip(a * 40 + 120, 0, 255).astype(np.uint8)
    m = api.compress_array(v, effort="max", max_error=1)
    assert np.abs(api.decompress_array(m).astype(int) - v).max() <= 1
    assert payload(m) <= payload(api.compress_array(v, max_error=1))


def inner_bytes(blob: bytes) -> list[int]:
    """The first byte of each brick's inner section (after the flag byte)."""
    with Reader(blob) as r:
        return [take_section(memoryview(p), 1, "inner")[0][0] for _, _, p in r]


@pytest.mark.parametrize("dtype", [np.uint8, np.int16, np.uint16, np.int32])
@pytest.mark.parametrize("e", [1, 7, 60])
def test_fast_integers_decode_to_the_quantisers_reconstruction(dtype, e):
    """effort 'fast' codes the quantised voxels of integers with the fast codec (inner
    byte 6): the decoder gives back exactly lo + q * step of lossy-1.md steps 1 and 3,
    computed here in Python integers, clipped to the dtype, on every voxel."""
    a = smooth_volume((18, 21, 40), np.int16, seed=9).astype(np.int64)
    info = np.iinfo(dtype)
    a = np.clip((a - a.min()) * (min(info.max, 3000) - max(info.min, 0)) // np.ptp(a), 0, None)
    a = (a + max(info.min, 0) if dtype != np.int32 else a * 1000 - 70000).astype(dtype)
    blob = api.compress_array(a, max_error=e, effort="fast", brick=16)
    assert set(inner_bytes(blob)) == {QVOX_FAST}
    back = api.decompress_array(blob)
    lo, step = int(a.min()), 2 * e + 1
    q = (a.astype(np.int64) - lo + e) // step
    want = np.clip(lo + q * step, info.min, info.max).astype(dtype)
    assert back.dtype == dtype and np.array_equal(back, want)
    assert np.abs(back.astype(np.int64) - a).max() <= e


def test_fast_integer_payload_cut_or_damaged_is_a_format_error():
    a = smooth_volume((16, 16, 16), np.int16, seed=2)
    codec = BoundedCodec.plan(a.dtype, int(a.min()), int(a.max()), 5.0, effort="fast")
    payload = codec.encode(a)
    assert payload[5] == QVOX_FAST
    np.testing.assert_array_equal(codec.decode(payload, a.shape, a.dtype), api.decompress_array(
        api.compress_array(a, max_error=5, effort="fast", brick=16)))
    for cut in (6, len(payload) // 2, len(payload) - 1):
        with pytest.raises(FormatError):
            codec.decode(payload[:cut], a.shape, a.dtype)
    bad = bytearray(payload)
    bad[6] = 9  # the fast payload's mode byte: no such mode
    with pytest.raises(FormatError):
        codec.decode(bytes(bad), a.shape, a.dtype)


@pytest.mark.parametrize("rel", [1e-2, 1e-3, 1e-4])
def test_fast_floats_decode_to_the_encoders_reconstruction(rel, monkeypatch):
    """effort 'fast' on a float brick: the interpolation path, its bins grouped unless
    the static coding is FAST_ADAPTIVE_SAVING shorter (it decodes 1.4-1.7x slower) or
    the adaptive one FAST_ADAPTIVE_OVER_GROUPED shorter than the shorter of those
    (2-3.5x slower), or the quantised voxels by the fast codec (inner byte 6); either way the
    decoder gives the encoder's reconstruction cast to float32 bit for bit, but at the
    voxels the cast pushed past E (stored exactly), and the bound on every voxel."""
    a = smooth_float((22, 26, 30), np.float64, seed=6)  # off its grid of 1/7: no exact path
    a = (a + np.random.default_rng(6).uniform(0, 0.1, a.shape)).astype(np.float32)
    e = float(np.ptp(a)) * rel
    codec = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), e, effort="fast")
    payload, err, _sse, _n = codec.encode_measured(a)
    inner = take_section(memoryview(payload), 1, "inner")[0]
    back = codec.decode(payload, a.shape, a.dtype)
    assert np.abs(back.astype(np.float64) - a).max() == err <= e
    g = a.astype(np.float64)
    if payload[0] & FLAG_INTERP:
        tried = bounded_interp.TRIED_FAST
        grouped, rec = bounded_interp.encode(g, codec.step, tried, ("grouped",))
        static, _ = bounded_interp.encode(g, codec.step, tried, ("static",))
        adaptive, _ = bounded_interp.encode(g, codec.step, tried, ("adaptive",))
        monkeypatch.setattr(bounded_interp, "SHARED_TABLES", False)
        plain, _ = bounded_interp.encode(g, codec.step, tried, ("static",))
        # (the encoder weighs the static coding by its estimate, here by its length)
        want = grouped if len(plain) >= (1 - FAST_ADAPTIVE_SAVING) * len(grouped) else static
        if len(adaptive) < (1 - FAST_ADAPTIVE_OVER_GROUPED) * min(len(grouped), len(plain)):
            want = adaptive
        # the static coding's tables shared (session 35): kept where the rule, made again
        # with its length, keeps it and it is no longer than the choice above
        over = len(adaptive) < (1 - FAST_ADAPTIVE_OVER_GROUPED) * min(len(grouped), len(static))
        if len(static) < (1 - FAST_ADAPTIVE_SAVING) * len(grouped) and not over:
            want = static if len(static) <= len(want) else want
        assert bytes(inner) == want
        if want is adaptive:
            return
    else:
        assert inner[0] == QVOX_FAST
        q = np.clip(np.rint((g - codec.lo) / codec.step), 0, np.iinfo(codec.qdtype).max)
        rec = q * codec.step + codec.lo
    big = np.finfo(np.float32).max
    rebuilt = np.clip(rec, -big, big).astype(np.float32)
    assert np.all((back == rebuilt) | ((back == a) & (np.abs(rebuilt - a) > e)))


def _palette_field(dtype):
    """A float field on 90 irregular levels (0.01 apart at least) with noise of 0.004:
    at E = 0.005 its quantised voxels leave most values of their range unused, so the
    fast codec codes their ranks in a palette."""
    a = smooth_volume((12, 20, 24), np.int16, seed=4).astype(np.float64)
    a = (a - a.min()) / np.ptp(a) * 200
    rng = np.random.default_rng(5)
    levels = np.sort(rng.choice(4000, 90, replace=False)) * 0.01
    return (levels[np.clip(a.astype(int) // 3, 0, 89)] + rng.uniform(-4e-3, 4e-3, a.shape)).astype(
        dtype
    )


@pytest.mark.parametrize(
    "case", ["palette-f32", "palette-f64", "plain-f32", "plain-f64", "int16", "uint8"]
)
def test_fast_quantised_voxels_rebuilt_from_the_work_array_match_the_plain_reading(
    case, monkeypatch
):
    """The quantised voxels of a fast payload are rebuilt from the fast decoder's own
    work array (no copy to ``qdtype``) or, with a palette, through a table of the
    palette's rebuilt values: the same voxels as the fast codec's own decoding of ``q``
    followed by tests/naive.py's step 3, into a brick of a larger volume too; the whole
    payload (mask, corrections) decodes alike into both. (The interpolation path, which
    codes the noisy field shorter, is left out.)"""
    import naive

    from volpack.volume_codec import lossy
    from volpack.volume_codec.fast import FastCodec, decode_parts

    monkeypatch.setattr(lossy, "FAST_INTERP_SAVING", 1.0)

    dtype = {"f32": np.float32, "f64": np.float64}.get(case[-3:])
    if case.startswith("palette"):
        a, e = _palette_field(dtype), 0.005
    elif case.startswith("plain"):
        a = smooth_float((14, 17, 19), np.float64, seed=8)  # noisy: no interpolation path
        a, e = (a + np.random.default_rng(8).normal(0, 30, a.shape)).astype(dtype), 0.01
    else:
        dtype = np.dtype(case)
        a = smooth_volume((14, 17, 19), np.int16, seed=8)
        a, e = (a - a.min()).astype(dtype) if dtype == np.uint8 else a, 2
        a = np.minimum(a, 255).astype(dtype) if dtype == np.uint8 else a
    codec = BoundedCodec.plan(a.dtype, a.min().item(), a.max().item(), e, effort="fast")
    payload = codec.encode(a)
    inner = memoryview(take_section(memoryview(payload), 1, "inner")[0])
    assert inner[0] == QVOX_FAST
    qd = np.dtype(codec.qdtype)
    _values, palette, _kinds = decode_parts(inner[1:], a.shape, qd)
    assert (palette is not None) == case.startswith("palette")
    q = FastCodec().decode(inner[1:], a.shape, qd)
    want = naive.bounded_reconstruct(q, codec.lo, codec.step, a.dtype)
    np.testing.assert_array_equal(codec._reconstruct_fast(inner[1:], a.shape, a.dtype), want)
    vol = np.zeros((a.shape[0] + 2, a.shape[1], a.shape[2] + 3), a.dtype)
    view = vol[1:-1, :, 3:]
    np.testing.assert_array_equal(codec._reconstruct_fast(inner[1:], a.shape, a.dtype, view), want)
    back = codec.decode(payload, a.shape, a.dtype)
    vol[...] = 0
    codec.decode_into(payload, view)
    np.testing.assert_array_equal(view, back)
    assert not vol[0].any() and not vol[-1].any() and not vol[:, :, :3].any()
    fixed = back != want  # the corrections' voxels, stored exactly
    np.testing.assert_array_equal(back[fixed], a[fixed])
    assert np.abs(back.astype(np.float64) - a).max() <= e


def test_fast_quantised_voxels_of_float16_take_numpys_path():
    """A palette payload of quantised voxels rebuilt as float16 (no kernel takes it): the
    plain step 3 of the fast codec's decoding, not an internal error."""
    import naive

    from volpack.volume_codec.fast import FastCodec, decode_parts

    a = _palette_field(np.float32).astype(np.float16)
    codec = BoundedCodec.plan(a.dtype, a.min().item(), a.max().item(), 0.01)
    qd = np.dtype(codec.qdtype)
    payload = FastCodec(zstd=False).encode(codec._quantize(a))
    assert decode_parts(payload, a.shape, qd)[1] is not None  # a palette
    q = FastCodec().decode(payload, a.shape, qd)
    want = naive.bounded_reconstruct(q, codec.lo, codec.step, np.float16)
    np.testing.assert_array_equal(codec._reconstruct_fast(payload, a.shape, a.dtype), want)
