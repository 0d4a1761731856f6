"""The default version's pruned float selection (lossless.PRUNE_FLOAT: zstd 19 judged on a
sample, the fit left out where the blend wins anyway, a central block ranking the Lorenzo
predictors and gating the blend and the split floats) against the full search: the bytes
within 0.1 % of it, special values back bit for bit, the same bytes for any worker count;
and the exact rewrites (palette and lattice search by sorts, packed gaps) against their
naive references."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import benchmark_volume

from volpack import api
from volpack.volume_codec import floatcode, floatprobe, lossless
from volpack.volume_codec import floatpredict as fp
from volpack.volume_codec import palette as pal

TOLERANCE = 0.001  # the task's bound on a volume's bytes


def same_bits(a, b):
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def both(brick, monkeypatch) -> tuple[bytes, bytes]:
    codec = lossless.LosslessCodec()
    monkeypatch.setattr(lossless, "PRUNE_FLOAT", True)
    pruned = codec.encode(brick)
    monkeypatch.setattr(lossless, "PRUNE_FLOAT", False)
    return pruned, codec.encode(brick)


def periodic(shape=(40, 48, 64), seed=3):
    """A noisy field repeating every 24 columns (a unit cell: the blend's copies)."""
    rng = np.random.default_rng(seed)
    cell = rng.normal(0, 1, (shape[0], shape[1], 24)).cumsum(axis=1).astype(np.float32)
    return np.ascontiguousarray(np.tile(cell, (1, 1, -(-shape[2] // 24)))[..., : shape[2]])


def with_specials(a: np.ndarray, seed=4) -> np.ndarray:
    """``a`` with NaN (two payloads), +-Inf, -0.0 and denormals scattered through it."""
    a = a.copy()
    flat = a.reshape(-1)
    rng = np.random.default_rng(seed)
    idx = rng.choice(flat.size, 70, replace=False)
    tiny = np.finfo(a.dtype).smallest_subnormal
    flat[idx[:10]] = np.nan
    flat[idx[10:20]] = np.inf
    flat[idx[20:30]] = -np.inf
    flat[idx[30:40]] = -0.0
    flat[idx[40:55]] = tiny * rng.integers(1, 100, 15)
    flat[idx[55:70]] = -tiny
    bits = flat.view("u4")
    bits[idx[5]] |= 0x12345  # a NaN payload
    return a


@pytest.mark.parametrize(
    "name,crop",
    [
        ("tgv_u", np.s_[:]),  # the fit wins
        ("ct_skull_float", np.s_[:]),  # the blend wins
        ("sst_monthly", np.s_[:, :, :96]),  # a lattice wins
        ("md_water", np.s_[:]),  # the palette's ranks win
    ],
)
def test_pruned_float_choice_within_the_margin_of_the_full_search(name, crop, monkeypatch):
    brick = np.ascontiguousarray(np.asarray(benchmark_volume(name))[crop])
    pruned, full = both(brick, monkeypatch)
    assert len(pruned) <= (1 + TOLERANCE) * len(full), (len(pruned), len(full))
    back = lossless.LosslessCodec().decode(pruned, brick.shape, brick.dtype)
    assert same_bits(back, brick)


def test_pruned_selection_skips_what_cannot_win(monkeypatch):
    """On the DNS brick zstd 19 and the split floats are not run in full, nor the blend
    on a brick a lattice wins by far; and the payloads are the full search's."""
    full_calls = []
    split = floatcode.encode
    monkeypatch.setattr(
        floatcode, "encode", lambda o, n: full_calls.append(("split", o.size)) or split(o, n)
    )
    zstd = lossless.ZstdCodec.encode
    monkeypatch.setattr(
        lossless.ZstdCodec,
        "encode",
        lambda self, b: full_calls.append((f"zstd{self.level}", b.size)) or zstd(self, b),
    )
    brick = np.ascontiguousarray(np.asarray(benchmark_volume("tgv_u")))
    pruned, full = both(brick, monkeypatch)
    n = len(full_calls) // 2  # (the calls of the pruned run come first)
    probe = floatprobe.Probe(brick)
    assert ("zstd19", brick.size) not in full_calls[:n] and ("zstd19", brick.size) in full_calls[n:]
    assert ("split", brick.size) not in full_calls[:n] and (
        "split",
        probe.block.size,
    ) in full_calls[:n]
    assert pruned == full


# slow set: the only fast user of its kernel signatures (session 34, scripts/pytest_kerneluse.py)
@pytest.mark.slow
def test_specials_round_trip_bit_for_bit_when_pruned(monkeypatch):
    monkeypatch.setattr(lossless, "PRUNE_FLOAT", True)
    codec = lossless.LosslessCodec()
    z, y, x = np.indices((48, 40, 36))
    smooth = (np.sin(x * 0.07 + y * 0.05) * np.cos(z * 0.04) * 40).astype(np.float32)
    for a in (
        with_specials(smooth),
        with_specials(periodic()),
        with_specials(smooth.astype(np.float64)),
    ):
        assert floatprobe.Probe.make(a) is not None  # the block is made: the pruned path runs
        payload = codec.encode(a)
        assert same_bits(codec.decode(payload, a.shape, a.dtype), a)


def test_pruned_floats_deterministic_for_any_worker_count():
    a = np.concatenate([periodic((32, 48, 64)), periodic((32, 48, 64), seed=5) * 1e-3])
    one = api.compress_array(a, brick=(32, 48, 64), workers=1)
    assert api.compress_array(a, brick=(32, 48, 64), workers=2) == one
    assert same_bits(api.decompress_array(one), a)


def test_sorted_unique_and_packed_gaps_match_the_naive_ones():
    rng = np.random.default_rng(7)
    for v in (rng.integers(-(2**40), 2**40, 5000), rng.integers(0, 9, 5000), np.array([5])):
        assert np.array_equal(pal.sorted_unique(v), np.unique(v))
        p = np.unique(v)
        gaps = np.diff(p) - 1
        naive = pal.uleb(len(p)) + pal.uleb(int((p[0] << 1) ^ (p[0] >> 63)))
        naive += b"".join(pal.uleb(int(g)) for g in gaps)
        assert pal.pack(p) == naive
    big = np.array([0, 1, 127, 128, 16383, 16384, 2**62, 2**63 - 1])
    assert pal.uleb_many(big) == b"".join(pal.uleb(int(g)) for g in big)


def naive_fit(v):
    """The lattice candidates as the base tree computed them (np.unique of every value)."""
    u = np.unique(v)
    if u.size < 3:
        return []
    gaps = np.diff(u)
    est = float(gaps[gaps <= 1.5 * gaps.min()].mean())
    if not est > 0:
        return []
    steps = {est, round(est, 2 - int(np.floor(np.log10(est))))}
    n = round((u[-1] - u[0]) / est)
    if n >= 1:
        steps.add(float((u[-1] - u[0]) / n))
    out = []
    for step in sorted(steps):
        if step > 0:
            rest, count = np.unique(v - step * np.rint(v / step), return_counts=True)
            out += [(0.0, step), (float(rest[np.argmax(count)]), step)]
    return out


def test_lattice_candidates_match_the_naive_ones():
    rng = np.random.default_rng(8)
    k = rng.integers(-300, 300, 4000).astype(np.float64)
    cases = [
        0.37 + 0.05 * k,  # an offset lattice
        np.where(k > 250, -999.0, 0.01 * k),  # a fill value off it
        np.concatenate([0.5 * k, [-0.0, 0.0, -0.0]]),  # signed zeros
        rng.normal(0, 1, 4000).astype(np.float32).astype(np.float64),  # none
    ]
    for v in cases:
        got = fp._fit(v)
        want = naive_fit(v)
        assert [(np.float64(a).tobytes(), b) for a, b in got] == [
            (np.float64(a).tobytes(), b) for a, b in want
        ]


def naive_find_lattices(brick):
    """The lattice search as the base tree ran it (every slice fitted, no early exit)."""
    if not np.isfinite(brick).all():
        return []

    def narrow(k):
        kspan = int(k.max()) - int(k.min()) + 1
        s = fp.to_signed(brick)
        sspan = int(s.max()) - int(s.min()) + 1
        return kspan <= (1 << (np.finfo(brick.dtype).nmant + 1)) and kspan << 3 <= sspan

    limit = fp.LATTICE_MAX_MISS * brick.size
    found, best = [], None
    for off, step in naive_fit(brick.astype(np.float64).reshape(-1)):
        got = fp._lattice_k(brick, np.array([[off, step]]))
        if got is not None and (best is None or got[0] < best[0][0]):
            best = (got, np.array([[off, step]]))
    if best is not None and best[0][0] <= limit and narrow(best[0][1]):
        found.append((best[1], best[0][1], best[0][2]))
    rows = []
    for sl in brick:
        cands = naive_fit(sl.astype(np.float64).reshape(-1)) + rows[-1:] + [(0.0, 1.0)]
        scored = [(fp._lattice_k(sl[None], np.array([c])), c) for c in cands]
        scored = [(g[0], i, c) for i, (g, c) in enumerate(scored) if g is not None]
        if not scored:
            return found
        rows.append(min(scored)[2])
    params = np.array(rows)
    got = fp._lattice_k(brick, params)
    if got is not None and found and all(map(np.array_equal, got[1:], found[0][1:])):
        got = None
    if got is not None and got[0] <= limit and narrow(got[1]):
        found.append((params, got[1], got[2]))
    return found


def test_lattice_search_with_early_exits_finds_the_same_lattices():
    rng = np.random.default_rng(9)
    k = rng.integers(0, 500, (20, 30, 40))
    scales = 0.01 * (1 + np.arange(20))[:, None, None]
    packed = (100 + scales * k).astype(np.float32)  # one scale per slice
    one = (0.25 * k).astype(np.float32)  # one lattice
    fine = np.linspace(1, 1.5, k.size, dtype=np.float32).reshape(k.shape)  # the floats' own
    noisy = packed + rng.normal(0, 1e-3, k.shape).astype(np.float32) * (k > 250)
    for a in (packed, one, fine, noisy, rng.normal(0, 1, k.shape).astype(np.float32)):
        got, want = fp.find_lattices(a), naive_find_lattices(a)
        assert len(got) == len(want)
        for g, w in zip(got, want):
            assert all(np.array_equal(x, y) for x, y in zip(g, w))
    assert len(fp.find_lattices(packed)) == 2 and len(fp.find_lattices(one)) == 1
