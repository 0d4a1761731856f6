"""The fast codec's encoder after its session-23 speed-up writes main's bytes: encodings
pinned to the hashes main (28ad5ad) wrote, the per-class table scaling against scaling
every cut whole, the narrow-range palette against sorting."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from volpack.demo import load_demo_volume
from volpack.entropy import rans
from volpack.volume_codec import fastpredict
from volpack.volume_codec import palette as pal
from volpack.volume_codec.fast import FastCodec


def _sources():
    d = load_demo_volume().data
    cut = d[16:48, 16:48, 16:48]
    z, y, x = np.mgrid[:40, :48, :56]
    rng = np.random.default_rng(23)
    f = 3000 + 2000 * np.sin(x / 7.0) * np.cos(y / 9.0) + 300 * z / 40 + rng.normal(0, 4, x.shape)
    return {
        "u8": (cut.copy(), True),
        "i16-palette": (cut.astype(np.int16) * 37 - 3000, True),
        "labels": (np.digitize(cut, [40, 90, 140]).astype(np.uint8), True),
        "quantised": (np.rint(f).astype(np.uint16), False),  # as lossy --effort fast codes
        "quantised-gaps": (np.rint(f / 3).astype(np.uint16) * 3, False),  # a palette
    }


# (bytes, sha256 prefix) of main's FastCodec(zstd=...).encode at 28ad5ad
MAIN = {
    "u8": (8534, "3382bd1d49f474aee0cf59adc11bfa58"),
    "i16-palette": (8676, "46a2087bc81a873ad61308d705b54752"),
    "labels": (422, "6aff76ad0e0211bbea31c7a129fcef83"),
    "quantised": (73472, "1b84fa82bb7de6fa9fd0b5904b313d7e"),
    "quantised-gaps": (53721, "dfb64d35bf5e211370215fe0a274f781"),
}


@pytest.mark.parametrize("name", sorted(MAIN))
def test_encoder_writes_mains_bytes(name):
    a, zstd = _sources()[name]
    got = FastCodec(zstd=zstd).encode(a)
    assert (len(got), hashlib.sha256(got).hexdigest()[:32]) == MAIN[name]


def _cap_every_cut_whole(counts):
    """The class cap as main chose it: every cut's tables scaled whole, priced by
    :func:`fastpredict.pack_tables`' length."""
    used = np.flatnonzero(counts.sum(axis=1))
    top = int(used[-1]) + 1 if used.size else 1
    best = None
    for nctx in range(max(1, top - 12), top + 1):
        merged = counts[:nctx].copy()
        merged[nctx - 1] += counts[nctx:].sum(axis=0)
        freqs = rans.normalise(merged)
        nz = merged > 0
        cost = -(merged[nz] * np.log2(freqs[nz] / rans.TOTAL)).sum()
        cost = cost + 8 * len(fastpredict.pack_tables(freqs))
        if best is None or cost < best[2]:
            best = (nctx, freqs, cost)
    return best


@pytest.mark.parametrize("seed", range(12))
def test_cap_contexts_matches_scaling_every_cut(seed):
    rng = np.random.default_rng(seed)
    counts = np.zeros((fastpredict.NCLASS, rans.MAX_SYMBOLS), dtype=np.int64)
    rows = rng.integers(1, fastpredict.NCLASS + 1)
    for c in range(rows):
        if rng.random() < 0.2:
            continue  # an empty class between used ones
        width = rng.integers(1, 200)  # tables past 128 entries take two-byte lengths
        counts[c, :width] = (
            rng.geometric(rng.uniform(0.01, 0.5), width)
            * rng.integers(0, 2, width)
            * rng.integers(1, 3000)
        )
    if seed == 0:
        counts[:] = 0  # nothing coded
    if seed == 1:
        counts[:] = 0
        counts[3, 7] = 5  # one symbol in one class
    nctx, freqs, cost = fastpredict.cap_contexts(counts)
    want = _cap_every_cut_whole(counts)
    assert nctx == want[0] and cost == want[2]
    assert np.array_equal(freqs, want[1])


@pytest.mark.parametrize(
    "lo,span,n",
    [
        (0, 255, 5000),
        (-3000, 9000, 3000),
        (7, 0, 10),
        (-(1 << 40), 1 << 33, 2000),
        (0, (1 << 22) - 1, 100),
    ],
)
def test_palette_over_a_range_matches_sorting(lo, span, n):
    rng = np.random.default_rng(span % 97)
    v = lo + rng.integers(0, span + 1, size=(n,), dtype=np.int64)
    v[0], v[-1] = lo, lo + span
    v = v.reshape(1, 1, -1)
    p = pal.build_span(v, lo, lo + span)
    assert np.array_equal(p, np.unique(v))
    r = pal.to_ranks(v, p)
    assert r.dtype == np.int64 and r.shape == v.shape
    assert np.array_equal(p[r], v)
