"""The separable CDF 9/7 decomposition and its scan (volpack/wavelet/packet.py), and the
bounded codec's float wavelet path over it (scan order 3, formats/lossy-1.md step 10)."""

from __future__ import annotations

import numpy as np
import pytest
from naive import cdf97_transform

from volpack import api
from volpack.errors import FormatError
from volpack.format.container import Reader
from volpack.format.sections import take_section
from volpack.volume_codec import bounded_cdf97
from volpack.volume_codec.lossy import FLAG_CDF97
from volpack.wavelet import dwt3, packet


def naive_separable(x, levels, backward=False):
    """Each axis's full 1-D transform on its own, through the naive Mallat reference with
    one active axis (the spec's definition)."""
    axes = (2, 1, 0) if backward else (0, 1, 2)
    for a in axes:
        if levels[a]:
            one = [0, 0, 0]
            one[a] = levels[a]
            x = cdf97_transform(x, tuple(one), backward)
    return x


@pytest.mark.parametrize("shape", [(9, 13, 20), (1, 7, 33), (2, 2, 2), (6, 5, 1)])
def test_separable_transform_matches_the_naive_reference_bit_for_bit(shape):
    x = np.random.default_rng(3).standard_normal(shape) * 100
    full = dwt3.levels_for_shape(shape, None)
    for lv in {full, (full[0], 0, full[2]), (0, full[1], full[2])}:
        c = packet.forward(x, lv)
        np.testing.assert_array_equal(c, naive_separable(x, lv))
        np.testing.assert_array_equal(packet.inverse(c, lv), naive_separable(c, lv, True))
        np.testing.assert_allclose(packet.inverse(c, lv), x, atol=1e-10)


@pytest.mark.parametrize(
    "shape,levels",
    [
        ((9, 13, 20), (4, 4, 5)),
        ((6, 7, 1), (3, 0, 0)),
        ((5, 8, 3), (3, 3, 2)),
        ((1, 1, 1), (0, 0, 0)),
    ],
)
def test_separable_bands_tile_the_array_and_parents_come_first(shape, levels):
    seen = np.zeros(shape, int)
    bands = packet.subbands(shape, levels)
    assert len(bands) == np.prod([lv + 1 for lv in levels])
    for b in bands:
        seen[tuple(slice(s, s + n) for s, n in zip(b.start, b.size))] += 1
    assert (seen == 1).all()
    sc = packet.scan(shape, levels)
    n = int(np.prod(shape))
    np.testing.assert_array_equal(np.sort(sc.perm), np.arange(n))
    i = np.arange(n)
    assert (sc.parent < i).all()  # coded before their children (-1: roots)
    assert (sc.nbr < i[:, None]).all()
    assert ((sc.end > i) & (sc.end <= n)).all()


def reference_scan(shape, levels):
    """The separable scan as numpy built it before session 30 (one band at a time, int64
    tables): the slow reference of the kernel's."""
    bands = packet.subbands(shape, levels)
    by_index = {b.index: b for b in bands}
    total = int(np.prod(shape))
    strides = (shape[1] * shape[2], shape[2], 1)

    def flat(start, local):
        z, y, x = (s + loc for s, loc in zip(start, local))
        return ((z * shape[1] + y) * shape[2] + x).ravel()

    parent_flat = np.full(total, -1, np.int64)
    cls_flat = np.zeros(total, np.uint8)
    nbr_flat = np.full((total, 3), -1, np.int64)
    order, end, start = [], np.arange(1, total + 1), 0
    for b in bands:
        idx = flat(b.start, np.ix_(*(np.arange(s) for s in b.size)))
        order.append(idx)
        grid = np.indices(b.size).reshape(3, -1)
        for a in range(3):
            nbr_flat[idx[grid[a] > 0], a] = idx[grid[a] > 0] - strides[a]
        cls_flat[idx] = packet._band_class(b, levels)
        if b.size[2] > 1:  # the first position of each row roots the row
            firsts = start + b.size[2] * np.arange(b.size[0] * b.size[1])
            end[firsts] = firsts + b.size[2]
        start += idx.size
        up = packet._parent(b, levels)
        pb = by_index.get(up) if up is not None else None
        if pb is not None:
            ploc = [
                np.minimum(
                    np.arange(b.size[a]) // (2 if up[a] != b.index[a] else 1), pb.size[a] - 1
                )
                for a in range(3)
            ]
            parent_flat[idx] = flat(pb.start, np.ix_(*ploc))
    perm = np.concatenate(order)
    pos = np.empty(total, np.int64)
    pos[perm] = np.arange(total)
    pf, nf = parent_flat[perm], nbr_flat[perm]
    parent = np.where(pf >= 0, pos[np.maximum(pf, 0)], -1)
    nbr = np.where(nf >= 0, pos[np.maximum(nf, 0)], -1)
    return perm, end, parent, cls_flat[perm], nbr


@pytest.mark.parametrize(
    "shape,levels",
    [((9, 13, 20), (4, 4, 5)), ((6, 7, 1), (3, 0, 0)), ((5, 8, 3), (3, 3, 2)),
     ((16, 12, 10), (2, 4, 1)), ((1, 1, 1), (0, 0, 0)), ((17, 1, 9), (0, 0, 4))],
)  # fmt: skip
def test_separable_scan_matches_the_numpy_reference(shape, levels):
    sc = packet.scan(shape, levels)
    assert [a.dtype for a in sc] == [np.int32, np.int32, np.int32, np.uint8, np.int32]
    for got, want in zip(sc, reference_scan(shape, levels)):
        np.testing.assert_array_equal(got, want)


def test_separable_scan_round_trips_through_every_coder():
    from volpack.entropy import CODERS

    shape, levels = (7, 10, 12), (3, 4, 4)
    sc = packet.scan(shape, levels)
    q = np.random.default_rng(1).integers(-9, 10, shape) * (
        np.random.default_rng(2).random(shape) < 0.3
    )
    for coder in CODERS.values():
        out = np.empty(shape, np.int64)
        coder.decode(coder.encode(q.copy(), sc), sc, out)
        np.testing.assert_array_equal(out, q)


def rough_along_x(shape=(24, 30, 40), seed=0):
    """Smooth across z and y, noise along x: each x-detail band is still smooth in z and
    y, which only the separable layout goes on to transform."""
    r = np.random.default_rng(seed)
    z, y = np.meshgrid(*(np.linspace(0, 2, n) for n in shape[:2]), indexing="ij")
    u = np.sin(z * 1.7 + y) + 0.5 * np.cos(2 * y - z)
    return (u[:, :, None] * r.standard_normal(shape[2])[None, None, :]).astype(np.float32)


def _inner(blob):
    with Reader(blob) as r:
        (payload,) = [p for _, _, p in r]
    return payload, take_section(memoryview(payload), 1, "inner")[0]


@pytest.mark.parametrize("rel", [1e-3, 3e-4])
def test_the_encoder_takes_the_separable_layout_where_it_codes_shorter(rel, monkeypatch):
    a = rough_along_x()
    e = float(a.max() - a.min()) * rel
    blob = api.compress_array(a, max_error=e)
    payload, inner = _inner(blob)
    assert payload[0] & FLAG_CDF97 and inner[3] == bounded_cdf97.SEPARABLE
    got = api.decompress_array(blob)
    assert np.abs(got.astype(np.float64) - a).max() <= e
    monkeypatch.setattr(bounded_cdf97, "TRIED_ORDERS", (1, 2))  # the Mallat layout alone
    mallat = api.compress_array(a, max_error=e)
    assert len(blob) < 0.9 * len(mallat)


def test_a_bad_scan_order_is_a_format_error():
    a = rough_along_x((8, 9, 10))
    blob = api.compress_array(a, max_error=0.05)
    _, inner = _inner(blob)
    bad = bytearray(inner)
    bad[3] = 4
    with pytest.raises(FormatError, match="order"):
        bounded_cdf97.decode(bytes(bad), a.shape, "arith", None)


def test_separable_levels_may_be_partial_and_are_checked():
    """Scan order 3 takes any level count up to the full one on at least two axes."""
    from volpack.volume_codec.bounded_cdf97 import HEADER

    a = rough_along_x((8, 9, 10))
    lv = (1, 2, 4)
    c = packet.forward(a.astype(np.float64), lv)
    q = np.rint(c / 0.01).astype(np.int64)
    from volpack.entropy import CODERS

    body = CODERS["arith"].encode(q.copy(), packet.scan(a.shape, lv))
    rec = bounded_cdf97.decode(HEADER.pack(*lv, 3, 0.01) + body, a.shape, "arith", None)
    np.testing.assert_array_equal(rec, packet.inverse(q * 0.01, lv))
    for bad in [(5, 2, 4), (0, 0, 4)]:  # past the full count (4, 4, 4); one axis alone
        with pytest.raises(FormatError, match="levels"):
            bounded_cdf97.decode(HEADER.pack(*bad, 3, 0.01) + body, a.shape, "arith", None)
    with pytest.raises(FormatError, match="levels"):  # the Mallat layout: none or all
        bounded_cdf97.decode(HEADER.pack(*lv, 2, 0.01) + body, a.shape, "arith", None)
