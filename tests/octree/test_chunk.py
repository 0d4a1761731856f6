"""A node's chunk decoded in one kernel (volpack.octree.chunk) against the step-by-step
path of ``Octree._lift_up`` and the numpy numbers it checks with."""

from __future__ import annotations

import io
import itertools

import numpy as np
import pytest
from conftest import smooth_volume

from volpack.octree import NodeDamaged, Octree, build, chunk, layout


def _build(vol, **kw) -> bytes:
    buf = io.BytesIO()
    build(vol, buf, **kw)
    return buf.getvalue()


def _all_chunks(t):
    return [(lv, i) for lv in range(1, t.depth + 1) for i in np.ndindex(*t.geometry.grid(lv))]


@pytest.mark.parametrize(
    ("shape", "dtype", "kw"),
    [
        ((37, 21, 30), np.int16, {"block": 4}),
        ((33, 40, 17), np.uint8, {"block": 4}),
        # int64 work: a signature of its own, compiled by no other fast test (5 s)
        pytest.param((20, 9, 26), np.int32, {"block": 4}, marks=pytest.mark.slow),
        ((37, 21, 30), np.int16, {"block": 4, "max_error": 3.0}),  # bounded: a quantiser step
        ((9, 1, 33), np.uint16, {"block": 4}),  # an axis of one voxel: no lifting along it
    ],
)
def test_fused_chunks_equal_the_step_by_step_path(shape, dtype, kw, monkeypatch):
    blob = _build(smooth_volume(shape, dtype, seed=sum(shape), noise=9.0), **kw)
    calls = []
    fused = Octree._lift_up_fused

    def counted(self, *a):
        out = fused(self, *a)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(Octree, "_lift_up_fused", counted)
    with Octree(blob) as a, Octree(blob) as b:
        b._lift_up_fused = lambda *a: None  # the step-by-step path
        a.prefetch(_all_chunks(a), workers=2)
        b.prefetch(_all_chunks(b))
        assert calls and all(calls)
        assert a._cache.keys() == b._cache.keys() and a.decoded_nodes == b.decoded_nodes
        for key, (block, corr) in a._cache.items():
            ref, ref_corr = b._cache[key]
            assert block.dtype == ref.dtype and block.flags.c_contiguous
            np.testing.assert_array_equal(block, ref)
            assert corr == ref_corr
        np.testing.assert_array_equal(a.decode(0).data, b.decode(0).data)


@pytest.mark.parametrize("shape", [(32, 32, 32), (32, 32, 13), (2, 32, 18), (16, 1, 9), (1, 1, 7), (3, 5, 9)])
def test_energy_sum_is_numpys_pairwise_sum(shape):
    r = np.random.default_rng(len(shape) + sum(shape))
    for _ in range(4):
        c = (r.standard_normal(shape) * r.integers(1, 5000, shape)).astype(np.int64)
        c[r.random(shape) < 0.5] = 0
        scale = r.random(c.size) * 4
        want = float(np.sum(np.square(c.astype(np.int32) * scale.reshape(shape))))
        assert chunk._energy_sum(c.reshape(-1), scale) == want  # bit for bit


@pytest.mark.parametrize(("grid", "kgrid"), [((3, 2, 5), (5, 4, 9)), ((2, 2, 2), (4, 4, 4)), ((4, 1, 3), None)])
def test_energy_bounds_equal_own_energy_range(grid, kgrid):
    r = np.random.default_rng(7)

    def table(g):
        e = (r.random(int(np.prod(g))) * 10.0 ** r.integers(-40, 30, int(np.prod(g)))).astype(np.float32)
        e[::4] = 0
        e[1::7] = np.float32(1e-45)  # the smallest subnormal: the next float32 down is 0
        return e

    e = table(grid)
    kids = table(kgrid) if kgrid else np.zeros(0, np.float32)
    lo, hi = chunk.energy_bounds(e, kids, grid, kgrid or (0, 0, 0))
    for n, index in enumerate(np.ndindex(*grid)):
        idx = [np.ravel_multi_index(b, kgrid)
               for b in itertools.product(*((2 * i, 2 * i + 1) for i in index))
               if all(v < g for v, g in zip(b, kgrid))] if kgrid else []  # fmt: skip
        want = layout.own_energy_range(e[n], kids[idx])
        assert (lo[n], hi[n]) == want  # bit for bit


def test_a_chunk_failing_the_energy_check_is_reported_as_before():
    vol = smooth_volume((37, 21, 30), np.int16, seed=3, noise=6.0)
    blob = _build(vol, block=4)
    with Octree(blob) as t:
        lo, hi = t._energy_bounds(1)
        t._bounds[1] = (lo + hi.max() + 1.0, hi + hi.max() + 2.0)  # nothing fits
        t._energy_matches = lambda *a: False  # the step-by-step path agrees
        with pytest.raises(NodeDamaged, match="error E"):
            t.decode(0)


# the tabled decoder called on its own: a signature no fast test compiles (the fast set
# runs it inside the fused kernel, on valid chunks, above)
@pytest.mark.slow
@pytest.mark.parametrize("shape", [(32, 32, 32), (9, 1, 33), (5, 6, 2)])
def test_tabled_decoder_equals_the_arith_decoder_on_valid_and_damaged_streams(shape):
    from volpack.entropy import arith
    from volpack.wavelet.sigmap import scan as make_scan

    rng = np.random.default_rng(sum(shape))
    lv = layout.lift_levels(shape)
    s = make_scan(shape, lv, "dfs")
    tab = arith.context_table(s)
    c = np.round(rng.laplace(0, 3, shape) * (rng.random(shape) < 0.3)).astype(np.int64)
    c[rng.random(shape) < 0.01] = 1 << 20  # long bit lengths: the count up to 21
    good = np.frombuffer(arith.encode(c, s), np.uint8)
    cases = [good, good[:-1], good[: len(good) // 2], np.append(good, np.uint8(7)),
             np.zeros(0, np.uint8)]  # fmt: skip
    for _ in range(20):  # one byte flipped somewhere
        bad = good.copy()
        bad[rng.integers(len(bad))] ^= np.uint8(1 << rng.integers(8))
        cases.append(bad)
    for nmax in (63, 12):  # 12: an "impossible" bit length for the long coefficients
        for data in cases:
            a, b = np.zeros(c.size, np.int64), np.zeros(c.size, np.int64)
            sa = arith.decode_kernel(data, s.perm, s.end, s.parent, s.cls, s.nbr, a, nmax)
            sb = arith.decode_tabled_kernel(data, s.perm, s.end, tab, s.cls, b, nmax)
            assert sa == sb
            np.testing.assert_array_equal(a, b)
    a = np.zeros(c.size, np.int64)
    assert arith.decode_tabled_kernel(good, s.perm, s.end, tab, s.cls, a, 63) == 0
    np.testing.assert_array_equal(a, c.reshape(-1))
