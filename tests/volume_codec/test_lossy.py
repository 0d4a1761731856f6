"""Lossy coding: the error bound holds on every voxel, targets are reached, special
values come back exactly, and the method's quality knob behaves."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import slow_case, smooth_volume
from hypothesis import given, settings
from hypothesis import strategies as st

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.format.sections import take_section
from volpack.volume_codec.lossy import RD_WEIGHT, BoundedCodec, CoefCodec, band_scale
from volpack.volume_codec.protocol import Measured


def field(kind: str, shape, dtype, seed: int) -> np.ndarray:
    """Test volumes of the kinds that break error-bounded coders."""
    r = np.random.default_rng(seed)
    if kind == "noise":
        f = r.normal(0, 100, shape)
    elif kind == "steps":
        f = np.where(np.indices(shape)[2] < shape[2] // 2, -300.0, 700.0) + r.normal(0, 1, shape)
    elif kind == "spikes":
        f = np.zeros(shape)
        f.flat[r.integers(0, f.size, max(1, f.size // 50))] = r.choice(
            [-1e4, 1e4], max(1, f.size // 50)
        )
    elif kind == "constant":
        f = np.full(shape, 42.0)
    else:  # smooth
        f = smooth_volume(shape, np.int16, seed=seed).astype(np.float64)
    if np.dtype(dtype).kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(f), info.min, info.max).astype(dtype)
    return f.astype(dtype)


def decode_damaged(codec, payload, shape, dtype, seed, count):
    """Truncated or bit-flipped payloads decode to the right shape or raise FormatError."""
    rng = np.random.default_rng(seed)
    for i in range(count):
        bad = bytearray(payload)
        if i % 3 == 0:
            bad = bad[: int(rng.integers(len(bad)))]
        else:
            bad[int(rng.integers(len(bad)))] ^= 1 << int(rng.integers(8))
        try:
            assert codec.decode(bytes(bad), shape, dtype).shape == tuple(shape)
        except FormatError:
            pass


def check_bound(a, b, bound):
    ok = np.isfinite(a) if a.dtype.kind == "f" else np.ones(a.shape, bool)
    err = np.abs(b[ok].astype(np.float64) - a[ok].astype(np.float64))
    assert err.max(initial=0.0) <= bound, (err.max(), bound)
    if a.dtype.kind == "f":  # specials come back bit for bit
        np.testing.assert_array_equal(
            a[~ok].view(np.uint8 if a.itemsize == 1 else f"u{a.itemsize}"),
            b[~ok].view(np.uint8 if a.itemsize == 1 else f"u{a.itemsize}"),
        )


@settings(max_examples=30)
@given(
    kind=st.sampled_from(["noise", "steps", "spikes", "constant", "smooth"]),
    dtype=st.sampled_from(["uint8", "int16", "uint16", "int32", "float32", "float64"]),
    shape=st.tuples(st.integers(1, 20), st.integers(1, 20), st.integers(1, 20)),
    rel=st.sampled_from([1e-6, 1e-3, 0.05, 0.5, 1.0, 3.0]),
    nan_island=st.booleans(),
    seed=st.integers(0, 1000),
)
def test_max_error_holds_on_every_voxel(kind, dtype, shape, rel, nan_island, seed):
    a = field(kind, shape, dtype, seed)
    if nan_island and a.dtype.kind == "f":
        a[: max(1, shape[0] // 2), :3, :3] = np.nan
        a.flat[-1] = -np.inf
    valid = a[np.isfinite(a)] if a.dtype.kind == "f" else a
    span = float(valid.max() - valid.min()) if valid.size else 0.0
    bound = max(rel * span, 1e-3 if a.dtype.kind == "f" else 0.5)
    blob = api.compress_array(a, max_error=bound, brick=8)
    b = api.decompress_array(blob)
    assert b.dtype == a.dtype and b.shape == a.shape
    check_bound(a, b, bound)
    with Reader(blob) as r:  # the index records each brick's achieved error, within bound
        assert all(e.error <= bound for e in r.entries)
        assert r.summary["max_error"] <= bound


@pytest.mark.slow  # the float64 lossless encoders, which no other fast test compiles
def test_float_extremes_and_denormals():
    a = np.array([0.0, 1e-45, -1e-45, 3.4e38, -3.4e38, 1.0, np.nan, np.inf], np.float32)
    a = np.resize(a, (4, 4, 8)).copy()
    for bound in (1e30, 1e36, 1e39):
        check_bound(a, api.decompress_array(api.compress_array(a, max_error=bound)), bound)
    with pytest.raises(ValueError, match="2\\^31"):  # 10^68 levels: a clear refusal
        api.compress_array(a, max_error=1e-30)
    tiny = np.resize(np.array([0.0, 1e-45, -1e-45, 3e-42, -7e-40], np.float32), (3, 3, 5))
    for bound in (1e-45, 1e-41):  # denormals, down to the smallest step
        check_bound(tiny, api.decompress_array(api.compress_array(tiny, max_error=bound)), bound)
    big = np.full((4, 4, 4), 1e300)  # float64 beyond float32's range
    big[0, 0, 0] = -1e300
    check_bound(big, api.decompress_array(api.compress_array(big, max_error=1e295)), 1e295)
    # two values: a grid of one step (search.lattice), exact even under 1e-300
    check_bound(big, api.decompress_array(api.compress_array(big, max_error=1e-300)), 1e-300)
    big[1, 1, 1] = 0.123  # now 10^301 levels: a clear refusal
    with pytest.raises(ValueError, match="2\\^31"):
        api.compress_array(big, max_error=1e-300)


# slow set: 2-4 CPU s of its own (session 34: the fast set reached its 6 minutes)
@pytest.mark.slow
def test_fill_value_is_restored_and_does_not_spoil_neighbours(brain):
    a = brain[20:52, 30:94, 30:94].astype(np.float32)
    f = a.copy()
    f[:, :10, :] = -2.56e33  # a climate-style fill band
    lossy = api.compress_array(f, max_error=0.5, fill_value=-2.56e33)
    b = api.decompress_array(lossy)
    assert (b[:, :10, :] == np.float32(-2.56e33)).all()
    check_bound(a[:, 10:, :], b[:, 10:, :], 0.5)
    # Without the mask the fill value would dominate the range and the step.
    ref = api.compress_array(a, max_error=0.5)
    assert len(lossy) < 1.3 * len(ref)


# slow set: about 6 CPU s of its own (session 34, the fast set near its 6 minutes)
@pytest.mark.slow
def test_zero_bound_is_lossless_for_integers_and_floats(brain):
    b = api.decompress_array(api.compress_array(brain[:16], max_error=0))
    np.testing.assert_array_equal(b, brain[:16])
    # a bound under 1 leaves every integer voxel as it is: the lossless codec's file, not
    # the bounded codec's quantised voxels (3 % longer on the whole scan)
    exact = api.compress_array(brain[:16])
    for kw in ({"max_error": 0}, {"max_error": 0.99}, {"rel_error": 0.9 / int(np.ptp(brain[:16]))}):
        assert api.compress_array(brain[:16], **kw) == exact, kw
    assert api.compress_array(brain[:16], max_error=0.5, effort="max") == api.compress_array(
        brain[:16], effort="max"
    )
    assert api.info(api.compress_array(brain[:16], max_error=1))["summary"]["mode"] == "bounded"
    # a bound of 0 on floats: the lossless file too (it was refused before session 28)
    f = brain[:16].astype(np.float32) / 7
    assert api.compress_array(f, max_error=0) == api.compress_array(f)
    assert api.compress_array(f, rel_error=0.0) == api.compress_array(f)


@pytest.fixture(scope="module")
def scan16():
    """A CT-like 16-bit volume: smooth anatomy and a noise floor."""
    return smooth_volume((64, 96, 96), np.int16, seed=4, noise=6.0)


@pytest.mark.parametrize("target", [45.0, 60.0])
def test_psnr_target_is_reached(scan16, target):
    st, blob = run(scan16, psnr=target, workers=2)
    assert abs(st["psnr"] - target) <= 0.5
    b = api.decompress_array(blob)
    mse = np.mean((b.astype(np.float64) - scan16) ** 2)
    psnr = 10 * math.log10(float(scan16.max() - scan16.min()) ** 2 / mse)
    assert abs(psnr - st["psnr"]) < 1e-6  # what is reported is what decodes


@pytest.mark.parametrize("target", [8.0, 30.0])
def test_ratio_target_is_reached(scan16, target):
    st, blob = run(scan16, ratio=target, workers=2)
    # the target is the file's ratio, container included (what `ls` shows)
    assert abs(st["file_ratio"] / target - 1) <= 0.05, st["search"]
    assert st["file_ratio"] == scan16.nbytes / len(blob)
    # the file keeps what `info` shows, not the search's steps (the caller has those)
    kept = api.info(blob)["summary"]["search"]
    assert len(st["search"]["steps"]) >= 2 and "steps" not in kept
    assert kept["target"] == "ratio" and kept["value"] == target
    assert kept["reached"] == pytest.approx(st["file_ratio"], rel=0.01)  # container estimated


def test_ratio_target_is_the_files_on_a_small_field():
    """On a 64 KB field the container is 5-7 % of a 20:1 file: the search counts it, so
    the file itself comes out within 5 % of the target (it was 18.7:1 for 20)."""
    a = smooth_volume((16, 32, 32), np.int16, seed=3).astype(np.float32) / 7
    for target in (10.0, 20.0):
        st, blob = run(a, ratio=target)
        assert abs(a.nbytes / len(blob) / target - 1) <= 0.05, (target, st["search"])


@pytest.mark.slow
def test_unreachable_target_reports_the_closest(brain):
    # 8-bit noise makes the rate jump where a whole band's |c| = 8 leaves the zero bin:
    # the file comes out near 8:1 (within 5 % today), reported as reached.
    st, _ = run(brain, ratio=8.0, workers=2)
    # reached: the file's ratio as the search estimates the container (a few hundred bytes)
    assert st["search"]["reached"] == pytest.approx(st["file_ratio"], rel=2e-3)
    assert abs(st["file_ratio"] / 8 - 1) < 0.2


def test_a_missed_target_keeps_the_nearest_within_tolerance_then_the_safe_side(caplog):
    from volpack.volume_codec.search import _closest, _warned

    # (setting, what the whole volume reached): within 0.5 dB wins, however near others are
    assert _closest([(1.0, 49.45), (2.0, 50.3), (3.0, 49.9)], "psnr", 50) == (3.0, 49.9)
    # a jump from 49.48 to 50.93 dB: the PSNR at or above the target, though further off
    with caplog.at_level("WARNING", logger="volpack.volume_codec.search"):
        assert _closest([(0.95, 49.48), (0.91, 50.93), (0.5, 61.2)], "psnr", 50) == (0.91, 50.93)
        assert not caplog.text  # a search's miss is told for the record kept, not each search
        _warned((None, {"target": "psnr", "value": 40.0, "reached": 40.33}))
        assert not caplog.text
        _warned((None, {"target": "psnr", "value": 50.0, "reached": 50.93}))
    assert "psnr 50: not reached within 0.5 dB by any setting tried; kept 50.93" in caplog.text
    assert _closest([(0.95, 41.0), (1.2, 38.0)], "psnr", 50) == (0.95, 41.0)  # none above
    # a ratio: a file no larger than asked (7.2 is nearer to 8 than 9.1 in log terms too)
    assert _closest([(1.0, 7.2), (2.0, 9.1)], "ratio", 8) == (2.0, 9.1)
    assert _closest([(1.0, 7.2), (2.0, 8.3)], "ratio", 8) == (2.0, 8.3)


def _clouds(n=32, seed=0):
    """Four smooth blobs with a little noise in a field of exact zeros (97.6 % of it): an
    isabel_qcloud in small."""
    rng = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*[np.arange(n)] * 3, indexing="ij")
    a = np.zeros((n, n, n))
    for _ in range(4):
        c, r = rng.uniform(4, n - 4, 3), rng.uniform(3, 7)
        d2 = ((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) / r**2
        a += np.where(d2 < 1, (1 - d2) ** 2 * rng.uniform(0.5, 1), 0)
    a += 0.02 * rng.standard_normal(a.shape) * (a > 0)
    return np.where(a > 0.05, a, 0).astype(np.float32)


def test_a_psnr_target_chooses_each_bricks_coding_by_rate_and_distortion():
    """A coding chosen by size alone gave the zeros back as other values within the bound
    and the PSNR jumped with the bound: at 48 dB the search kept 805 bytes at 49.41 dB
    with a warning, where a bound of 2.2 % of the range gives 54.1 dB in 661 (session 38,
    isabel_qcloud's 40 dB in small). Now no longer than that bound's file, on target."""
    a = _clouds()
    rng = float(a.max() - a.min())
    bound = api.compress_array(a, max_error=0.0221 * rng)
    st, blob = run(a, psnr=48)
    assert abs(st["psnr"] - 48) <= 0.5 and len(blob) <= len(bound), (st["search"], len(bound))
    # the choice itself: at 3.1 % of the range the interpolation path is the shortest the
    # size-only choice makes (490 bytes, 46.5 dB); the quantised voxels, 449 bytes at 51.5
    # dB with every zero exact, lose by size only because they were never made
    e = 0.0308 * rng
    by_size = BoundedCodec.plan(a.dtype, 0.0, float(a.max()), e).encode_measured(a)
    by_rd = BoundedCodec.plan(a.dtype, 0.0, float(a.max()), e, rd=RD_WEIGHT).encode_measured(a)
    assert len(by_rd.payload) <= len(by_size.payload) and by_rd.sse < by_size.sse / 2
    rec = BoundedCodec.plan(a.dtype, 0.0, float(a.max()), e).decode(by_rd.payload, a.shape, a.dtype)
    assert (rec[a == 0] == 0).all()


def test_a_slower_coding_under_a_psnr_target_must_save_its_share_of_the_bytes_not_the_cost():
    """keep_faster's SLOW_MIN_SAVING on the bytes: charged on the cost (bytes plus the
    distortion's share) it kept isabel_pfill's faster coding at 80 dB, 2.1 % longer at the
    same PSNR (session 38)."""
    from volpack.volume_codec.lossy import SLOW_MIN_SAVING, keep_faster

    fast = Measured(bytes(1000), 1.0, 4000.0, 100)
    slow = Measured(bytes(int(1000 * (1 - 1.5 * SLOW_MIN_SAVING))), 1.0, 4000.0, 100)
    def cost(m):
        return len(m.payload) + m.sse
    assert keep_faster([(0, fast), (1, slow)], SLOW_MIN_SAVING, cost) is slow
    assert keep_faster([(0, fast), (1, slow)], SLOW_MIN_SAVING) is slow  # by bytes alike
    slower = Measured(bytes(int(1000 * (1 - 0.5 * SLOW_MIN_SAVING))), 1.0, 4000.0, 100)
    assert keep_faster([(0, fast), (1, slower)], SLOW_MIN_SAVING, cost) is fast


def test_the_psnr_search_never_keeps_a_try_another_beats_in_size_and_psnr():
    from volpack.volume_codec.search import _undominated

    # isabel_qcloud at 40 dB (session 37): the search ended on 40.68 dB at 0.144 bpv,
    # where a try before it had 46.9 dB at 0.142
    whole = [(1.0, 46.9), (2.0, 38.7), (3.0, 40.3), (1.5, 40.68)]
    sizes = {1.0: 142, 2.0: 120, 3.0: 50, 1.5: 144}
    assert _undominated((1.5, 40.68), whole, sizes) == (1.0, 46.9)
    assert _undominated((1.0, 46.9), whole, sizes) == (1.0, 46.9)  # none beats it in both
    assert _undominated((2.0, 38.7), whole, sizes) == (3.0, 40.3)
    assert _undominated((3.0, 40.3), whole, sizes) == (3.0, 40.3)
    sizes[3.0] = 120  # a tie in size: the higher PSNR
    assert _undominated((2.0, 38.7), whole, sizes) == (3.0, 40.3)


def _plateaus(n=32, seed=5):
    """A field with two plateaus (0 and 0.6866, about 30 % of the voxels each; 0 is not
    the minimum) joined by a noisy ramp: a species' mass fraction, unburnt and burnt."""
    rng = np.random.default_rng(seed)
    z, y, x = np.mgrid[:n, :n, :n] / n
    s = np.sin(5 * x + 3 * y) * np.cos(4 * z)
    a = np.where(s > 0.3, 0.6866, np.where(s < -0.2, 0.0, 0.4 + 0.3 * s))
    a = a + np.where((s >= -0.2) & (s <= 0.3), 0.01 * rng.standard_normal(a.shape), 0)
    a[:2] = -0.05 + 0.01 * rng.standard_normal((2, n, n))  # a slab below the zero plateau
    return a.astype(np.float32)


def test_on_bins_puts_the_common_values_on_bin_centres():
    from volpack.volume_codec.lossy import on_bins

    lo, step = on_bins(-0.3, 0.2, (0.0,))  # one: the bins move, no narrower
    assert lo <= -0.3 and step == 0.2 and (0.0 - lo) / step == pytest.approx(round(-lo / step))
    lo, step = on_bins(-0.3, 0.2, (0.7, 0.0))  # two: a whole number of bins between them
    assert lo <= -0.3 and 0.1 <= step <= 0.2
    for m in (0.0, 0.7):
        assert (m - lo) / step == pytest.approx(round((m - lo) / step), abs=1e-9)
    # two closer than half a bin: the most common alone, bins as they were
    assert on_bins(-0.3, 0.2, (0.05, 0.0)) == pytest.approx((0.05 - 2 * 0.2, 0.2))


def test_a_psnr_target_puts_a_fields_plateaus_on_bin_centres(monkeypatch):
    """Session 39: s3d_oh64 (an OH mass fraction: 29 % of voxels at its minimum, 19 % at
    6.865e-4) took 0.603 bpv for 60 dB and 0.963 for 80 (85.5 dB); its PSNR jumped by
    3-10 dB between neighbouring bounds as the burnt plateau's value drifted across the
    bins. With both plateaus on bin centres: 0.480 and 0.831 bpv (80.0 dB). Here: fewer
    bytes at the same target, every plateau voxel back exactly; error bounds keep their
    bins and bytes."""
    from volpack.volume_codec import search

    a = _plateaus()
    st, blob = run(a, psnr=60)
    bounded = api.compress_array(a, max_error=0.003)
    monkeypatch.setattr(search, "MODE_SHARE", 2.0)  # no value is that common: bins as before
    st0, blob0 = run(a, psnr=60)
    assert abs(st["psnr"] - 60) <= 0.5 and abs(st0["psnr"] - 60) <= 0.5
    assert len(blob) < 0.95 * len(blob0), (len(blob), len(blob0))
    d = api.decompress_array(blob)
    assert (d[a == 0] == 0).all() and (d[a == np.float32(0.6866)] == np.float32(0.6866)).all()
    assert api.compress_array(a, max_error=0.003) == bounded


def test_a_psnr_target_on_a_field_it_codes_exactly_writes_its_file(caplog):
    """Session 39: a two-valued float field under --psnr 40 is coded exactly (PSNR inf);
    the search record's inf made the file's summary fail to write ("expected a
    JSON-serialisable summary")."""
    z, y, x = np.mgrid[:16, :16, :16]
    a = np.where(x + y > 14, 1.0, 2.7).astype(np.float32)
    st, blob = run(a, psnr=40)
    assert st["psnr"] is None and st["max_error"] == 0.0
    assert (api.decompress_array(blob) == a).all()
    assert "kept an exact coding" in caplog.text


def test_float_psnr_target_uses_the_bounded_path():
    a = smooth_volume((24, 40, 40), np.int16, seed=3).astype(np.float32) / 7
    st, _ = run(a, psnr=50)
    assert st["codec"]["id"] == "bounded" and abs(st["psnr"] - 50) <= 0.5


@pytest.mark.slow
def test_quality_scale_orders_ratio_and_psnr(brain):
    rows = []
    for q in (255, 127, 63, 31, 15):
        st, blob = run(brain, quality=q)
        b = api.decompress_array(blob)
        assert st["max_error"] == np.abs(b.astype(np.int64) - brain).max()
        rows.append((st["ratio"], st["psnr"]))
    ratios, psnrs = zip(*rows)
    assert list(ratios) == sorted(ratios) and list(psnrs) == sorted(psnrs, reverse=True)
    assert psnrs[0] > 45  # quality 255 is close to lossless


def test_threshold_zero_is_lossless_and_grows_the_error(brain):
    a = brain[:32]
    np.testing.assert_array_equal(api.decompress_array(api.compress_array(a, threshold=0)), a)
    st, _ = run(a, threshold=6)
    assert st["ratio"] > run(a)[0]["ratio"] and st["max_error"] > 0


@pytest.mark.slow
def test_lossy_bytes_do_not_depend_on_workers(brain):
    for kw in ({"max_error": 2}, {"quality": 63}, {"psnr": 48}):
        one = api.compress_array(brain, workers=1, **kw)
        assert api.compress_array(brain, workers=2, **kw) == one


def test_one_lossy_setting_at_a_time_and_clear_errors(brain):
    with pytest.raises(ValueError, match="at most one"):
        api.compress_array(brain, max_error=1, psnr=40)
    with pytest.raises(ValueError, match="integer"):
        api.compress_array(brain.astype(np.float32), quality=63)
    with pytest.raises(ValueError):
        api.compress_array(brain, ratio=0.5)


@pytest.mark.parametrize("kw", [{"max_error": 3}, {"quality": 31}])
def test_corrupt_lossy_bricks_never_crash(kw):
    a = smooth_volume((12, 12, 12), np.int16, seed=2).astype(
        np.float32 if "max_error" in kw else np.int16
    )
    a.flat[5] = np.nan if a.dtype.kind == "f" else a.flat[5]
    blob = api.compress_array(a, brick=12, **kw)
    with Reader(blob) as r:
        ((t, node, payload),) = list(r)
        codec_cfg = r.header["codec"]
    from volpack.volume_codec.registry import get_codec

    decode_damaged(get_codec(codec_cfg), payload, a.shape, a.dtype, seed=1, count=200)


def test_band_scale_is_orthonormal_units():
    s = band_scale((8, 8, 8), (3, 3, 3)).reshape(8, 8, 8)
    assert s[0, 0, 0] == pytest.approx(2**4.5)  # three low steps per axis
    assert s[7, 7, 7] == pytest.approx(2**-1.5)  # finest HHH: one high step per axis
    assert s[0, 0, 7] == pytest.approx(2**0.5)  # finest LLH


def test_codec_configs_round_trip():
    from volpack.volume_codec.registry import get_codec

    for c in (BoundedCodec.plan("float32", -1, 1, 0.01), CoefCodec(value_range=255.0, quality=63)):
        assert get_codec(c.get_config()) == c


def run(a, **kw):
    """``api.compress`` into memory: (stats, container bytes)."""
    import io

    buf = io.BytesIO()
    st = api.compress(a, buf, **kw)
    return st, buf.getvalue()


def test_loose_bounds_take_the_coefficient_path_and_still_hold(scan16):
    from volpack.volume_codec.lossy import FLAG_COEF
    from volpack.volume_codec.registry import get_codec

    for bound in (25, 120):
        blob = api.compress_array(scan16, max_error=bound)
        check_bound(scan16, api.decompress_array(blob), bound)
        with Reader(blob) as r:
            c = get_codec(r.header["codec"])
            coef = [(node, p) for _, node, p in r if p[0] & FLAG_COEF]
        assert coef, "a loose bound on smooth data should pick the coefficient path"
    from volpack.volume_codec import bricks

    node, payload = coef[0]
    shape = tuple(s.stop - s.start for s in bricks.brick_slices(scan16.shape, (64,) * 3, node))
    assert c.decode(payload, shape, scan16.dtype).shape == shape
    decode_damaged(c, payload, shape, scan16.dtype, seed=3, count=150)


@pytest.mark.parametrize("wavelet", ["d4", "c6", "cdf97"])
def test_float_wavelets_for_comparison(brain, wavelet):
    a = brain[10:60, 20:100, 30:90]
    st, blob = run(a, quality=63, wavelet=wavelet)
    b = api.decompress_array(blob)
    assert b.dtype == a.dtype and b.shape == a.shape
    err = np.abs(b.astype(np.float64) - a)
    assert err.max() == st["max_error"]
    mse = np.mean(err**2)
    assert st["psnr"] == pytest.approx(10 * math.log10(float(a.max() - a.min()) ** 2 / mse))
    assert 35 < st["psnr"] < 60 and st["ratio"] > 2
    f = a.astype(np.float32) / 3  # floats too
    fb = api.decompress_array(api.compress_array(f, quality=255, wavelet=wavelet))
    assert np.abs(fb - f).max() < 0.05 * float(f.max() - f.min())


def test_float_wavelets_are_refused_where_they_cannot_serve(brain):
    with pytest.raises(ValueError, match="lossy"):
        api.compress_array(brain, wavelet="cdf97")
    with pytest.raises(ValueError, match="error bound"):
        api.compress_array(brain, wavelet="d4", max_error=2)


def test_64_bit_integers_are_refused_with_a_clear_error():
    a = np.arange(4 * 4 * 4, dtype=np.uint64).reshape(4, 4, 4) + np.uint64(2**63)
    with pytest.raises(ValueError, match="64-bit integers are stored exactly"):
        api.compress_array(a, max_error=10)
    np.testing.assert_array_equal(api.decompress_array(api.compress_array(a)), a)


@pytest.mark.parametrize("dtype", [np.float32, slow_case(np.float64)])
@pytest.mark.parametrize("value", [-9999.0, 1e20])
def test_an_undeclared_fill_value_is_masked_when_shorter(dtype, value):
    """A sentinel marking a region (below or above the others) is taken out into the
    mask: stored exactly, the bound holding on every other voxel, and shorter than the
    same field coded with the sentinel in its predictions."""
    from volpack.volume_codec.specials import sentinel

    f = field("smooth", (16, 24, 28), dtype, 3) / 50 + 280
    z, y, x = np.indices(f.shape)
    region = y + x < 14  # a wedge of ground under the field, as in the storm data
    f[region] = value
    assert sentinel(f, None) == dtype(value)
    e = 0.5
    blob = api.compress_array(f, max_error=e)
    got = api.decompress_array(blob)
    np.testing.assert_array_equal(got[region], f[region])
    assert np.abs(got[~region].astype(np.float64) - f[~region]).max() <= e
    with Reader(blob) as r:
        ((_, _, payload),) = list(r)
        assert payload[0] & 1
        # 1e20 would need more than 2^31 bins of 2E: declared the volume's fill value
        assert r.header["codec"]["fill"] == (None if value < 0 else dtype(value))
    if value > 0:
        return  # no coding with it in the bins to compare with
    unmasked = BoundedCodec.plan(dtype, value, 310, e)
    assert len(payload) < len(unmasked._encode_masked(f, None)[0])


@pytest.mark.parametrize("value", [1e35, -9999.0])
def test_a_relative_bound_set_by_an_undeclared_fill_value_is_warned_of(caplog, value):
    """Hurricane Isabel's 1e35 over land (session 37, results/kinds37): a rel_error of the
    range it sets is a bound of 1e32, and the field came back as one value without a
    word. The encoder now says which value sets the range and how to keep it out; with
    the fill value declared, or on a field without one, it says nothing."""
    from volpack.volume_codec.search import fill_sets_range

    f = field("smooth", (8, 16, 16), np.float32, 3) / 50 + 280
    region = np.indices(f.shape)[0] < 2  # the two lowest levels under ground
    f[region] = value
    found = fill_sets_range(f, float(f.min()), float(f.max()))
    assert found is not None and found[0] == np.float32(value) and found[1] == 0.25
    with caplog.at_level("WARNING", logger="volpack.volume_codec.search"):
        api.compress_array(f, rel_error=1e-3)
    assert f"--fill-value {np.float32(value):g}" in caplog.text
    assert "on 25 % of the voxels sets that range" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="volpack.volume_codec.search"):
        api.compress_array(f, rel_error=1e-3, fill_value=value)
        api.compress_array(f[2:], rel_error=1e-3)
        api.compress_array(f, max_error=0.5)  # an absolute bound: the range does not matter
    assert caplog.text == ""


def test_a_psnr_target_over_a_range_an_undeclared_fill_value_sets_is_warned_of(caplog):
    """A PSNR's peak is the value range: with 1e35 over land any target holds however far
    off the temperatures come back, as a rel_error does (session 37)."""
    f = field("smooth", (8, 16, 16), np.float32, 3) / 50 + 280
    f[:2] = 1e35
    with caplog.at_level("WARNING", logger="volpack.volume_codec.search"):
        api.compress_array(f, psnr=60)
    assert "psnr 60 dB is measured against the range" in caplog.text
    assert "--fill-value 1e+35" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="volpack.volume_codec.search"):
        api.compress_array(f[2:], psnr=60)
    assert caplog.text == ""


def test_no_sentinel_where_the_extreme_value_is_part_of_the_field():
    """Zero background of a scan (next value 1 of 255) and a field whose extremes are
    rare are not fill values."""
    from volpack.volume_codec.specials import sentinel

    scan = np.zeros((8, 16, 16), np.float32)
    scan[:, 4:12, 4:12] = np.arange(1, 65, dtype=np.float32).reshape(8, 8) * 3
    assert sentinel(scan, None) is None
    smooth = field("smooth", (8, 16, 16), np.float32, 1)
    assert sentinel(smooth, None) is None
    assert sentinel(np.full((8, 8, 8), 5.0), None) is None


# float64: the only fast user of its kernel signatures (session 34), in the slow set
@pytest.mark.parametrize("dtype", [np.float32, pytest.param(np.float64, marks=pytest.mark.slow)])
@pytest.mark.parametrize("e", [0.49, 0.1, 1e-4, 1e-9])
def test_whole_number_floats_under_a_bound_below_half_come_back_exactly(dtype, e):
    """A scan saved as floats: bins of 1 (the header's step), every voxel exact, NaN
    restored; shorter than bins of 2E at a tight bound (1.4x at 1e-4: the quantised voxels
    off the integers by one voxel still suit the lossless codec's predictor), and a bound
    whose bins of 2E would be refused, above 2^31 of them, is met."""
    a = field("smooth", (12, 20, 24), np.int16, 5).astype(dtype)
    a[3, 4, 5:9] = np.nan
    blob = api.compress_array(a, max_error=e)
    got = api.decompress_array(blob)
    np.testing.assert_array_equal(got, a)  # NaN in the same places, the rest exact
    with Reader(blob) as r:
        assert r.header["codec"]["step"] == 1.0
    if e < 1e-6:
        return
    b = a.copy()
    b[0, 0, 0] += 0.123456789  # one voxel off the integers: bins of 2E again
    blob2 = api.compress_array(b, max_error=e)
    with Reader(blob2) as r:
        assert r.header["codec"]["step"] == 2 * e
    got2 = api.decompress_array(blob2)
    ok = ~np.isnan(b)
    assert np.abs(got2[ok].astype(np.float64) - b[ok]).max() <= e
    if e < 0.01:
        assert len(blob) < len(blob2) / 1.3


@pytest.mark.parametrize("dtype", [np.float32, slow_case(np.float64)])
def test_floats_on_a_decimal_grid_take_its_spacing_as_bins(dtype):
    """A field stored to 0.1 (GRIB-packed model output): under a bound below 0.05 the
    bins are the grid's spacing (0.1, refined from the data), every voxel within the
    bound, shorter than bins of 2E; above it, bins of 2E as usual."""
    from volpack.volume_codec.search import lattice

    k = np.rint(field("smooth", (10, 24, 30), np.float64, 7) / 3)  # whole tenths
    a = (k / 10 - 40).astype(dtype)
    g = lattice(a, None, 1e-3)
    assert g is not None and abs(g - 0.1) < 1e-9
    assert lattice(a, None, 0.06) is None  # bins of 2E = 0.12 are wider than the grid
    blob = api.compress_array(a, max_error=1e-3)
    with Reader(blob) as r:
        assert abs(r.header["codec"]["step"] - 0.1) < 1e-9
    got = api.decompress_array(blob)
    assert np.abs(got.astype(np.float64) - a).max() <= 1e-3
    noisy = a + np.random.default_rng(0).uniform(-1e-4, 1e-4, a.shape).astype(dtype)
    assert lattice(noisy, None, 1e-3) is None  # off the grid by more than E/4
    assert len(blob) < len(api.compress_array(noisy, max_error=1e-3))


@pytest.mark.parametrize("kind", ["smooth", "spikes", "steps"])
def test_arith2_coder_holds_the_bound_and_decodes_its_damage(kind):
    """The ``arith2`` coefficient coder under an error bound: every voxel within it, its
    residuals coded by ``arith2`` too, and damaged payloads refused or decoded to shape."""
    a = field(kind, (20, 24, 28), np.float32, 3)
    bound = 0.01 * float(a.max() - a.min() or 1.0)
    blob = api.compress_array(a, max_error=bound, coder="arith2")
    check_bound(a, api.decompress_array(blob), bound)
    lo, hi = float(a.min()), float(a.max())
    codec = BoundedCodec.plan(a.dtype, lo, hi, bound, coder="arith2")
    assert codec._residual_coder == "arith2"
    decode_damaged(codec, codec.encode(a), a.shape, a.dtype, 5, 30)


def test_default_coder_is_auto_and_static_holds_the_bound_through_its_damage(monkeypatch):
    """New bounded streams name the ``auto`` coder (arith or arith2 per coefficient
    stream); ``static`` holds the bound, and its damaged payloads (flipped bits, every
    cut) are refused with FormatError or decode to shape, never crash."""
    import functools

    from volpack.volume_codec import bounded_interp

    # the interpolation path's adaptive coding codes this field shorter: left out, so
    # that a coefficient path is kept
    static = functools.partial(bounded_interp.encode, codings=("static",))
    monkeypatch.setattr(bounded_interp, "encode", static)
    # (and its tables not shared: since session 35 that codes it shorter still)
    monkeypatch.setattr(bounded_interp, "SHARED_TABLES", False)
    a = field("smooth", (16, 18, 20), np.float32, 3)
    bound = 1e-3 * float(a.max() - a.min())
    lo, hi = float(a.min()), float(a.max())
    assert BoundedCodec.plan(a.dtype, lo, hi, bound).coder == "auto"
    codec = BoundedCodec.plan(a.dtype, lo, hi, bound, coder="static")
    payload = codec.encode(a)
    assert not payload[0] & 64  # a coefficient path (not the interpolation path's rANS)
    check_bound(a, codec.decode(payload, a.shape, a.dtype), bound)
    for k in range(0, len(payload), max(1, len(payload) // 40)):
        with pytest.raises(FormatError):
            codec.decode(payload[:k], a.shape, a.dtype)
    decode_damaged(codec, payload, a.shape, a.dtype, 5, 30)


def _levels_field(dtype=np.float32):
    """A packed field per level: a step of 1/4 with its own offset per z slice, so no
    grid spans the volume (search.lattice finds none)."""
    k = np.rint(field("smooth", (6, 20, 24), np.float64, 3) / 8)
    z = np.arange(k.shape[0])[:, None, None]
    return (k * 0.25 + 0.1 * math.sqrt(2) * z - 20).astype(dtype)


def test_a_step_per_slice_takes_the_exact_path_and_comes_back_bit_for_bit(monkeypatch):
    """Under bounds below the step the brick is coded exactly by the lossless codec
    (flag 128), shorter than the bounded paths; a loose bound keeps those."""
    from volpack.volume_codec import lossy
    from volpack.volume_codec.search import lattice

    a = _levels_field()
    assert lattice(a, None, 1e-3) is None
    lo, hi = float(a.min()), float(a.max())
    codec = BoundedCodec.plan(a.dtype, lo, hi, 1e-3)
    payload, err, sse, n = codec.encode_measured(a)
    assert payload[0] == lossy.FLAG_EXACT and err == 0 == sse and n == a.size
    np.testing.assert_array_equal(codec.decode(payload, a.shape, a.dtype), a)
    monkeypatch.setattr(lossy, "_exact_may_pay", lambda x, e: False)
    monkeypatch.setattr(lossy, "EXACT_PROXY", 0.0)
    assert len(payload) < len(codec.encode(a))
    monkeypatch.undo()
    loose = 0.05 * (hi - lo)
    blob = api.compress_array(a, max_error=loose)
    with Reader(blob) as r:
        assert all(p[0] != lossy.FLAG_EXACT for _, _, p in r)
    assert np.abs(api.decompress_array(blob).astype(np.float64) - a).max() <= loose


def test_repeated_slabs_take_the_exact_path_by_its_zstd_stand_in(monkeypatch):
    """Rough slices repeating with a period of 3 (a tiled domain): no lattice and a
    quarter of the voxels distinct, so the value tests of ``_exact_may_pay`` pass it by;
    byte-shuffled zstd sees the repeats, and the exact path (the lossless codec's
    copies) codes it in under half the bounded bytes at 1e-5 of the range."""
    from volpack.volume_codec import lossy

    rng = np.random.default_rng(5)
    a = np.ascontiguousarray(np.tile(rng.standard_normal((3, 32, 32)), (4, 1, 1)), np.float32)
    lo, hi = float(a.min()), float(a.max())
    assert not lossy._exact_may_pay(a, 1e-5 * (hi - lo))
    codec = BoundedCodec.plan(a.dtype, lo, hi, 1e-5 * (hi - lo))
    payload, err, sse, n = codec.encode_measured(a)
    assert payload[0] == lossy.FLAG_EXACT and err == 0 == sse and n == a.size
    np.testing.assert_array_equal(codec.decode(payload, a.shape, a.dtype), a)
    monkeypatch.setattr(lossy, "EXACT_PROXY", 0.0)
    bounded = codec.encode(a)
    assert bounded[0] != lossy.FLAG_EXACT and 2 * len(payload) < len(bounded)


def test_damaged_exact_payloads_raise_format_errors():
    a = _levels_field()
    codec = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), 1e-3)
    payload = codec.encode(a)
    assert payload[0] == 128
    for bad, dtype in [
        (bytes([128 | 1]) + payload[1:], a.dtype),  # with the mask flag
        (payload + b"\0", a.dtype),  # a stray byte
        (payload[:-3], a.dtype),  # cut short
        (payload, np.int16),  # on integer voxels
    ]:
        with pytest.raises(FormatError):
            codec.decode(bad, a.shape, dtype)



@pytest.mark.parametrize(
    "dtype, bound, effort, flags",
    [
        (np.float32, 5.0, "default", 1),  # loose: mask, and whichever path is shortest
        (np.float32, 1e-5, "default", 1 | 2),  # below float32's spacing: corrections
        (np.float32, 0.01, "fast", 1 | 64),  # the interpolation path
        (np.float64, 0.01, "default", 1),
        (np.int16, 3, "default", 0),
    ],
)
def test_decode_into_a_brick_inside_a_larger_volume(dtype, bound, effort, flags, monkeypatch):
    """Through any strides, with masked voxels and corrections: the same voxels as
    ``decode``, and nothing outside the brick touched."""
    from volpack.volume_codec import lossy

    # below the float spacing the exact path is shorter (its zstd stand-in sees that);
    # the bounded paths' corrections are what this test decodes
    monkeypatch.setattr(lossy, "EXACT_PROXY", 0.0)
    r = np.random.default_rng(7)
    a = (smooth_volume((10, 12, 14), seed=3) + r.normal(0, 2, (10, 12, 14))).astype(dtype)
    if a.dtype.kind == "f":
        a[2, 3:9, 4] = np.nan
        a[5, 5, 5] = -999.0
    lo, hi = float(np.nanmin(a[a != -999])), float(np.nanmax(a))
    codec = BoundedCodec.plan(dtype, lo, hi, bound, effort=effort, fill=-999.0)
    payload = codec.encode(a)
    assert payload[0] & flags == flags
    want = codec.decode(payload, a.shape, dtype)
    vol = np.full((13, 12, 19), 7, dtype)
    codec.decode_into(payload, vol[1:11, :, 3:17])
    np.testing.assert_array_equal(vol[1:11, :, 3:17], want)
    vol[1:11, :, 3:17] = 7
    assert (vol == 7).all()


def test_a_slower_coding_is_kept_only_where_it_saves_the_minimum():
    """keep_faster: the shortest coding, except that one of a slower decoding tier must
    save SLOW_MIN_SAVING of the bytes of the best faster one; ties keep the faster."""
    from volpack.volume_codec import lossy

    def m(n):
        return Measured(bytes(n), 0.0, 0.0, 1)

    s = lossy.SLOW_MIN_SAVING
    need = int(1000 * (1 - s))  # the longest slow coding that still saves enough
    assert 0 < s < 0.5
    fast, mid, slow = lossy.TIER_FAST, lossy.TIER_MID, lossy.TIER_SLOW
    assert len(lossy.keep_faster([(slow, m(need + 1)), (mid, m(1000))])[0]) == 1000
    assert len(lossy.keep_faster([(slow, m(need - 1)), (mid, m(1000))])[0]) == need - 1
    assert len(lossy.keep_faster([(mid, m(1000)), (fast, m(1000))])[0]) == 1000
    # a slow coding is measured against the best of the faster tiers, not the first
    got = lossy.keep_faster([(fast, m(1000)), (mid, m(need - 1)), (slow, m(need - 2))])
    assert len(got[0]) == need - 1
    # within a tier the shorter wins on any saving
    assert len(lossy.keep_faster([(slow, m(500)), (slow, m(499)), (mid, m(2000))])[0]) == 499


def slow_coding(payload) -> bool:
    """Whether a bounded payload took a slower-decoding coding: adaptive interpolation
    bins or the quantised voxels through the lossless codec's predictor."""
    from volpack.volume_codec import bounded_interp, lossy
    from volpack.volume_codec.lossless import MODE_PREDICT

    inner, _ = take_section(memoryview(payload), 1, "inner")
    if payload[0] & lossy.FLAG_INTERP:
        return bounded_interp.is_adaptive(inner)
    paths = lossy.FLAG_CDF97 | lossy.FLAG_COEF | lossy.FLAG_EXACT
    return not payload[0] & paths and inner[0] == MODE_PREDICT


def test_the_minimum_saving_moves_bricks_to_faster_codings_within_the_bound(monkeypatch):
    """With a saving no coding can make, the bounded encoder keeps none of the slower
    codings: the stream grows a little and still holds the bound."""
    from volpack.volume_codec import lossy

    monkeypatch.setattr(lossy, "_exact_may_pay", lambda x, e: False)
    monkeypatch.setattr(lossy, "EXACT_PROXY", 0.0)
    a = field("smooth", (12, 20, 24), np.float32, 5)
    bound = 1e-3 * float(a.max() - a.min())
    codec = BoundedCodec.plan(a.dtype, float(a.min()), float(a.max()), bound)
    free = codec.encode(a)
    assert slow_coding(free)  # adaptive bins, by 2 % or more
    monkeypatch.setattr(lossy, "SLOW_MIN_SAVING", 0.999)
    payload = codec.encode(a)
    assert not slow_coding(payload) and len(free) < len(payload)
    check_bound(a, codec.decode(payload, a.shape, a.dtype), bound)


def test_rebuilt_codecs_are_reused_only_for_configs_checked_alike():
    """get_codec keeps the codecs it rebuilt: an equal config gives the same object, but
    a value of another JSON type (True or 1.0 for 1) or sign (-0.0) is checked afresh."""
    from volpack.volume_codec.registry import get_codec

    a = smooth_volume((12, 10, 9)).astype(np.float32)
    cfg = Reader(api.compress_array(a, max_error=0.5)).header["codec"]
    cfg = {**cfg, "max_levels": 1}
    c = get_codec(cfg)
    assert get_codec(dict(cfg)) is c and c.max_levels == 1
    for bad in (True, 1.0, "1"):
        with pytest.raises(FormatError):
            get_codec({**cfg, "max_levels": bad})
    assert get_codec(cfg) is c
    plus = get_codec({**cfg, "value_range": 0.0})
    minus = get_codec({**cfg, "value_range": -0.0})
    assert math.copysign(1.0, plus.value_range) == 1.0
    assert math.copysign(1.0, minus.value_range) == -1.0
    for i in range(200):  # many configs: each still rebuilt right
        assert get_codec({**cfg, "max_error": 1.0 + i}).max_error == 1.0 + i
    with pytest.raises(FormatError):
        get_codec({**cfg, "max_error": float("nan")})
