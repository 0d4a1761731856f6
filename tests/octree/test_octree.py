"""Octree build, level-of-detail selection and decoding (volpack.octree)."""

from __future__ import annotations

import io
import json
import math

import naive_octree
import numpy as np
import pytest
from conftest import need, slow_case, smooth_volume

from volpack.errors import FormatError
from volpack.octree import NodeDamaged, Octree, build, layout
from volpack.octree import select as sel
from volpack.octree.plan import to_values
from volpack.octree.source import SourceSpec


def _build(vol, **kw) -> bytes:
    buf = io.BytesIO()
    build(vol, buf, **kw)
    return buf.getvalue()


@pytest.fixture(scope="module")
def vol():
    return smooth_volume((37, 21, 30), np.int16, seed=3, noise=6.0)


@pytest.fixture(scope="module")
def blob(vol):
    return _build(vol, block=4)


# -- hierarchy -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("shape", "dtype", "block"),
    [
        ((5, 3, 4), np.uint8, 16),  # smaller than one block: the root is the volume
        ((17, 17, 17), np.uint16, 16),  # one more than a block
        ((1000, 10, 10), np.int16, 16),  # non-cubic
        # an axis of one voxel; int32 work compiles a chunk kernel of its own
        pytest.param((9, 1, 33), np.int32, 4, marks=pytest.mark.slow),
    ],
)
def test_lossless_round_trip_any_shape(shape, dtype, block):
    a = smooth_volume(shape, dtype, seed=sum(shape))
    with Octree(_build(a, block=block)) as t:
        assert t.depth == layout.Geometry(shape, block).depth
        out = t.decode(0).data
        assert out.dtype == a.dtype and out.shape == a.shape
        np.testing.assert_array_equal(out, a)


def test_levels_equal_naive_pyramid(vol, blob):
    with Octree(blob) as t:
        levels, details = naive_octree.pyramid(vol, 4, "53", t.depth)
        for lv in range(t.depth + 1):
            got = t.decode(lv).data
            np.testing.assert_array_equal(got, to_values(t.plan, levels[lv]))
            assert got.shape == t.geometry.level_shape(lv)
        # stripped nodes are exactly the nodes whose details are all zero
        for (lv, b), (d, _) in details.items():
            idx = np.ravel_multi_index(b, t.geometry.grid(lv))
            key = layout.node_key(lv, int(idx))
            assert ((0, key) in t._r) == bool(d.any() or lv == t.depth)


def test_node_errors_equal_naive(vol, blob):
    with Octree(blob) as t:
        levels, details = naive_octree.pyramid(vol, 4, "53", t.depth)
        for lv in range(1, t.depth + 1):
            vals = to_values(t.plan, levels[lv])
            for j, b in enumerate(np.ndindex(*t.geometry.grid(lv))):
                row = t.table(lv)[j]
                assert row["maxdev"] == pytest.approx(
                    naive_octree.max_deviation(vol, vals, lv, 4, b), abs=1e-3
                )
                e = math.sqrt(naive_octree.subtree_energy(details, lv, b))
                assert row["E"] == pytest.approx(e, rel=1e-5, abs=1e-3)
                nbox = t.geometry.node_box(lv, b)
                assert row["vmin"] == vals[nbox].min() and row["vmax"] == vals[nbox].max()


def test_deviation_histogram_bounds_every_voxel(vol, blob):
    with Octree(blob) as t:
        lv = 2
        vals = t.decode(lv).data.astype(np.float64)
        f = 1 << lv
        for j, b in enumerate(np.ndindex(*t.geometry.grid(lv))):
            row = t.table(lv)[j]
            fp = t.geometry.footprint(lv, b)
            x = vol[fp].astype(np.float64)
            v = np.repeat(np.repeat(np.repeat(vals, f, 0), f, 1), f, 2)[fp]
            width = (row["vmax"] - row["vmin"]) / layout.HIST_BINS
            bins = (
                np.zeros(v.shape, int)
                if width == 0
                else np.minimum(((v - row["vmin"]) / width).astype(int), layout.HIST_BINS - 1)
            )
            dev = x - v
            assert (dev >= row["hist"][bins, 0] - 1e-3).all()
            assert (dev <= row["hist"][bins, 1] + 1e-3).all()


# -- lossy -----------------------------------------------------------------------------


@pytest.mark.parametrize("bound", [0.5, 2.0, 7.0])
def test_max_error_holds_on_every_voxel(vol, bound):
    st = {}
    buf = io.BytesIO()
    st = build(vol, buf, block=4, max_error=bound)
    with Octree(buf.getvalue()) as t:
        out = t.decode(0).data
    err = np.abs(out.astype(np.float64) - vol)
    assert err.max() <= bound
    assert st["max_error"] == err.max()
    mse = float(np.mean(err**2))
    peak = float(vol.max()) - float(vol.min())
    if mse:
        assert st["psnr"] == pytest.approx(10 * math.log10(peak**2 / mse), rel=1e-9)


def test_by_error_below_the_files_own_bound_is_refused(vol):
    with Octree(_build(vol, block=4, max_error=3.0)) as t:
        with pytest.raises(ValueError, match="at least 3"):
            sel.by_error(t, 1.0)
        out = t.assemble(sel.by_error(t, 3.0), level=0).data
        assert np.abs(out.astype(np.float64) - vol).max() <= 3.0


def test_max_error_float_with_corrections():
    r = np.random.default_rng(5)
    a = (1e6 + np.cumsum(r.normal(0, 0.02, (11, 13, 9)), axis=2)).astype(np.float32)
    bound = 0.01  # below float32 resolution near 1e6 (0.0625): corrections must keep it
    with Octree(_build(a, block=4, max_error=bound)) as t:
        out = t.decode(0).data
    assert out.dtype == np.float32
    assert np.abs(out.astype(np.float64) - a.astype(np.float64)).max() <= bound


def test_float_without_bound_is_refused():
    with pytest.raises(FormatError, match="max_error"):
        _build(np.zeros((4, 4, 4), np.float32))


def test_a_mask_is_refused_with_or_without_a_bound():
    """bool voxels: one line either way (under a bound the quantiser raised a ValueError)."""
    m = np.zeros((4, 4, 4), bool)
    with pytest.raises(FormatError, match="found bool"):
        _build(m)
    with pytest.raises(FormatError, match="integer or float voxels, found bool"):
        _build(m, max_error=0.5)


# -- selection -------------------------------------------------------------------------


def test_level_decode_reads_only_coarse_nodes():
    a = smooth_volume((64, 64, 64), np.uint16, seed=1, noise=20.0)
    blob = _build(a, block=8)
    with Octree(blob) as t:
        coarse = t.decode(1).data
        assert coarse.shape == (32, 32, 32)
        read = t.bytes_read
        finest_bytes = sum(e.nbytes for e in t._r.entries if layout.split_key(e.node)[0] == 1)
        assert read < len(blob) - finest_bytes  # the level-1 chunks were not read
        assert t.decoded_nodes == 1 + 8  # the root and the eight level-2 nodes


def test_roi_at_level_equals_slice(vol, blob):
    with Octree(blob) as t:
        full = t.decode(1).data
        part = t.decode(1, "3:20,5:21,7:8")
        assert part.data.shape == (9, 9, 1)
        np.testing.assert_array_equal(part.data, full[1:10, 2:11, 3:4])
        assert part.origin[0] == pytest.approx((1 + 0.5) * 2 - 0.5)


@pytest.mark.parametrize("bound", [0.0, 30.0, 200.0])
def test_by_error_bound_holds_on_every_voxel(vol, blob, bound):
    with Octree(blob) as t:
        nodes = sel.by_error(t, bound)
        out = t.assemble(nodes, level=0, interp="nearest")
        assert out.data.shape == vol.shape
        assert np.abs(out.data.astype(np.float64) - vol).max() <= bound
        if bound == 0:
            assert {lv for lv, _ in nodes} == {0}
        if bound == 200.0:
            assert min(lv for lv, _ in nodes) > 0


def test_selection_covers_volume_once(vol, blob):
    with Octree(blob) as t:
        for nodes in (sel.by_error(t, 40.0), sel.by_budget(t, voxels=3000)):
            cover = np.zeros(vol.shape, int)
            for lv, b in nodes:
                cover[t.geometry.footprint(lv, b)] += 1
            assert (cover == 1).all()


def test_by_budget_respects_budget_and_refines_largest_error(vol, blob):
    with Octree(blob) as t:
        small = sel.by_budget(t, voxels=1200)
        large = sel.by_budget(t, voxels=6000)
        assert sum(sel.node_voxels(t, *n) for n in small) <= 1200
        assert sum(sel.node_voxels(t, *n) for n in large) <= 6000
        assert len(large) > len(small)
        # the first split happens at the root, the next at its child of largest E
        kids = sel.children(t, t.depth, (0, 0, 0), t.geometry.footprint(t.depth, (0, 0, 0)))
        two = sel.by_budget(t, voxels=sum(sel.node_voxels(t, *c) for c in kids) + 1)
        assert sorted(two) == sorted(kids)
        nb = sel.by_budget(t, nbytes=t.chunk_nbytes(t.depth, (0, 0, 0)))
        assert all(lv >= t.depth - 1 for lv, _ in nb)


def test_by_view_culls_and_stops_by_projection():
    from volpack.render.camera import Camera
    from volpack.render.transfer import TransferFunction

    a = (smooth_volume((32, 32, 32), np.int16, seed=2, noise=10.0) // 4).astype(np.uint8)
    with Octree(_build(a, block=4)) as t:
        wide = Camera(azimuth=0, elevation=0, size=(64, 64))
        full, stats = sel.by_view(t, wide, voxels=10**6)
        assert stats["culled"] == 0
        zoomed = Camera(azimuth=0, elevation=0, zoom=4, size=(64, 64), look_at=(4, 16, 4))
        part, stats = sel.by_view(t, zoomed, voxels=10**6)
        assert stats["culled"] > 0
        covered = sum(sel.node_voxels(t, lv, b) << (3 * lv) for lv, b in part)
        assert covered < a.size
        tiny = Camera(azimuth=0, elevation=0, size=(4, 4))
        coarse, stats = sel.by_view(t, tiny, voxels=10**6)
        assert stats["projected"] > 0 and min(lv for lv, _ in coarse) > 0
        # a transfer function that hides values above the data's range: all transparent
        hide = TransferFunction(((0.0, 1, 1, 1, 0.0), (1000.0, 1, 1, 1, 0.0)))
        none, stats = sel.by_view(t, wide, tf=hide, voxels=10**6)
        assert none == [] and stats["transparent"] == 1
        show = TransferFunction(((0.0, 1, 0, 0, 0.0), (255.0, 1, 1, 1, 0.5)))
        sel_tf, stats = sel.by_view(t, wide, tf=show, voxels=10**6, max_pixel_error=1e-9)
        assert len(sel_tf) > 1
        # only bright voxels are visible: every one of them stays covered, down to leaves
        bright = TransferFunction(((0.0, 1, 1, 1, 0.0), (200.0, 1, 1, 1, 0.0), (201, 1, 1, 1, 1)))
        vis, stats = sel.by_view(t, wide, tf=bright, voxels=10**6, max_pixel_error=1e-9)
        assert stats["transparent"] > 0 and min(lv for lv, _ in vis) == 0
        cover = np.zeros(a.shape, bool)
        for lv, b in vis:
            cover[t.geometry.footprint(lv, b)] = True
        assert cover[a > 200].all() and not cover.all()


def test_by_view_memo_keeps_the_selection_and_is_reused(monkeypatch):
    """A walk's memo of the view-independent node results (TF error, transparency) gives
    the same selection as computing them afresh, for each view and each TF."""
    from volpack.render.camera import Camera
    from volpack.render.transfer import TransferFunction

    a = (smooth_volume((32, 32, 32), np.int16, seed=3, noise=10.0) // 4).astype(np.uint8)
    tfs = [TransferFunction(((0.0, 1, 0, 0, 0.0), (255.0, 1, 1, 1, 0.5))),
           TransferFunction(((0.0, 1, 1, 1, 0.0), (150.0, 1, 1, 1, 0.0), (151, 1, 1, 1, 1)))]  # fmt: skip
    memo: dict = {}
    with Octree(_build(a, block=4)) as t:
        for az in (0, 40, 200):
            cam = Camera(azimuth=az, elevation=15, size=(48, 48))
            for tf in tfs:
                fresh = sel.by_view(t, cam, tf=tf, voxels=40 * 4**3, max_pixel_error=1e-6)
                kept = sel.by_view(t, cam, tf=tf, voxels=40 * 4**3, max_pixel_error=1e-6,
                                   memo=memo)  # fmt: skip
                assert kept == fresh
        assert len(memo) == 2  # one entry per transfer function
        calls = []
        monkeypatch.setattr(sel, "tf_node_errors", lambda *a: calls.append(a) or 0.0)
        sel.by_view(t, Camera(azimuth=40, elevation=15, size=(48, 48)), tf=tfs[0],
                    voxels=40 * 4**3, max_pixel_error=1e-6, memo=memo)  # fmt: skip
        assert calls == []  # every node's error came from the memo


def test_tf_error_is_zero_for_constant_tf_and_grows_with_deviation():
    from volpack.render.transfer import TransferFunction

    row = np.zeros(1, layout.META_DTYPE)[0]
    row["vmin"], row["vmax"] = 10, 20
    row["hist"][:, 0], row["hist"][:, 1] = -1, 1
    flat = TransferFunction(((0.0, 0.5, 0.5, 0.5, 0.2), (100.0, 0.5, 0.5, 0.5, 0.2)))
    assert sel.tf_node_errors(flat, row[None], 10.0)[0] == pytest.approx(0.0, abs=1e-12)
    ramp = TransferFunction(((0.0, 0, 0, 0, 0.0), (100.0, 1, 1, 1, 0.5)))
    e1 = sel.tf_node_errors(ramp, row[None], 10.0)[0]
    row["hist"][:, 0], row["hist"][:, 1] = -5, 5
    assert sel.tf_node_errors(ramp, row[None], 10.0)[0] > e1 > 0


def test_tf_errors_and_ranges_match_a_node_by_node_reference():
    """The whole-level numpy forms against plain per-node loops (tests/naive_octree)."""
    from volpack.render.transfer import TransferFunction

    rng = np.random.default_rng(7)
    rows = np.zeros(40, layout.META_DTYPE)
    rows["vmin"] = rng.uniform(0, 150, 40)
    rows["vmax"] = rows["vmin"] + rng.uniform(0, 80, 40)
    rows["hist"] = rng.uniform(-6, 0, (40, 8, 2)) * [1, -1]
    rows["hist"][::5] = 0  # exact nodes
    tf = TransferFunction(((0.0, 0, 0, 0, 0.0), (60.0, 0.2, 0.1, 0.0, 0.0), (90.0, 1, 0.8, 0.6, 0.3),
                           (91.0, 1, 1, 1, 0.9), (255.0, 0.5, 0.5, 1, 0.6)))  # fmt: skip
    lo, hi = rng.uniform(0, 255, 40), rng.uniform(0, 255, 40)  # either order
    lo[:4], hi[4:8], hi[8] = (60.0, 90.0, 91.0, 0.0), (91.0, 90.0, 255.0, 60.0), lo[8]  # ends on points
    cmin, cmax = sel.tf_ranges(tf, lo, hi)
    for i in range(40):
        rmin, rmax = naive_octree.tf_range(tf.points, lo[i], hi[i])
        np.testing.assert_allclose(cmin[i], rmin, atol=1e-12)
        np.testing.assert_allclose(cmax[i], rmax, atol=1e-12)
    err = sel.tf_node_errors(tf, rows, 30.0)
    ref = [naive_octree.tf_node_error(tf.points, r, 30.0) for r in rows]
    np.testing.assert_allclose(err, ref, rtol=1e-5, atol=1e-9)
    assert (err[::5] == 0).all() and (err > 0).sum() >= 20


# -- decoding --------------------------------------------------------------------------


def test_linear_assembly_has_no_seams(vol, blob):
    with Octree(blob) as t:
        nodes = sel.by_level(t, 2)
        out = t.assemble(nodes, level=0, interp="linear").data
        ref = naive_octree.upsample_linear(t.decode(2).data, 4, vol.shape)
        np.testing.assert_array_equal(out, np.clip(np.rint(ref), -32768, 32767).astype(np.int16))


def test_a_level_resampled_over_any_box_gives_each_nodes_numbers(vol, blob):
    # what a walk's resident grid writes per box of several nodes (resident.update):
    # boxes cut anywhere give the voxels the whole-level upsampling gives there
    with Octree(blob) as t:
        ref = naive_octree.upsample_linear(t.decode(2).data, 4, vol.shape)
        ref = np.clip(np.rint(ref), -32768, 32767).astype(np.int16)
        for box in [(slice(0, 37), slice(0, 21), slice(0, 30)), (slice(3, 20), slice(5, 6), slice(7, 29))]:
            np.testing.assert_array_equal(t.resampled(2, box, 4), ref[box])
        np.testing.assert_array_equal(t.resampled(0, box, 1), vol[box])
        for lv, fm in [(2, 4), (1, 2), (0, 1)]:  # written into a view of a grid, as the walk does
            grid = np.full((40, 24, 33), 7, np.int16)
            t.resampled(lv, box, fm, out=grid[2:19, 1:2, 0:22])
            np.testing.assert_array_equal(grid[2:19, 1:2, 0:22], t.resampled(lv, box, fm))
            grid[2:19, 1:2, 0:22] = 7
            assert (grid == 7).all()  # nothing outside the box


@pytest.mark.parametrize("dtype", [np.uint8, np.int8, np.int16, np.uint16, np.int32, np.float32])
def test_trilinear_written_into_a_view_equals_the_cast_result(dtype):
    # an integer ``into`` of the dtype is stored by the kernel itself (no float64 copy):
    # the same numbers as the float64 result cast, at the clip limits and on rounding
    # ties too; nothing outside the view changes
    from volpack.octree.resample import axis_weights, trilinear

    rng = np.random.default_rng(5)
    top = np.iinfo(dtype).max if np.dtype(dtype).kind in "iu" else 1e3
    v = rng.choice([-1e9, -0.5, 0.5, 1.5, 2.5, top - 0.5, top + 0.5, 1e9], (5, 4, 6))
    v[1] = rng.normal(0, top / 2, (4, 6))
    ax = [axis_weights(1, 9, 2, n) for n in v.shape]
    v = v[tuple(slice(b, None) for b, *_ in ax)]
    want = trilinear(v, [a[1] for a in ax], [a[2] for a in ax], [a[3] for a in ax], dtype)
    grid = np.full((10, 11, 12), 3, dtype)
    got = trilinear(v, [a[1] for a in ax], [a[2] for a in ax], [a[3] for a in ax], dtype,
                    grid[1:9, 2:10, 3:11])  # fmt: skip
    assert got.base is grid or got.base is grid.base
    np.testing.assert_array_equal(grid[1:9, 2:10, 3:11], want)
    grid[1:9, 2:10, 3:11] = 3
    assert (grid == 3).all()


@pytest.mark.parametrize(
    "dtype", [np.uint8, np.int8, slow_case(np.uint16), np.int32, np.int64]
)  # uint16: a kernel of its own
def test_values_clipped_in_one_kernel_equal_to_values(dtype):
    # the kernel that writes a block's integers clipped into the tree's dtype (or float64)
    # against the numpy form of plan.to_values, with values outside the dtype's range
    from volpack.octree.plan import Plan
    from volpack.octree.resample import put_clipped

    info = np.iinfo(dtype)
    r = np.random.default_rng(5)
    plan = Plan((8, 8, 8), np.dtype(dtype).str, 4, "53", "arith", "dfs", "<i8", 0)
    lo, hi = plan.clip_range
    work = r.integers(max(info.min, -(1 << 62)) // 2 * 3 - 5, min(info.max, 1 << 62) // 2 * 3 + 5, (9, 8, 11))
    src = work[1:8, ::2, 3:]
    for out in (np.empty(src.shape, dtype), np.empty((12, 9, 9))[2:9, 5:9, 1:9]):
        put_clipped(src, lo, hi, out)
        np.testing.assert_array_equal(out, to_values(plan, src).astype(out.dtype))
    assert Plan((8, 8, 8), "<u8", 4, "53", "arith", "dfs", "<i8", 0).clip_range is None


def test_brick_border_matches_neighbours(vol, blob):
    with Octree(blob) as t:
        full = np.pad(t.decode(1).data, 1, mode="edge")
        for b in [(0, 0, 0), (1, 2, 3), (4, 2, 3)]:
            box = t.geometry.node_box(1, b)
            grown = tuple(slice(s.start, s.stop + 2) for s in box)
            np.testing.assert_array_equal(t.brick(1, b, border=1), full[grown])


def test_small_cache_gives_same_result(vol, blob):
    with Octree(blob, cache_bytes=1) as t:
        np.testing.assert_array_equal(t.decode(0).data, vol)


def test_threads_decode_each_node_once_and_give_the_same_result(vol, blob):
    with Octree(blob) as one, Octree(blob) as two:
        np.testing.assert_array_equal(two.decode(0, workers=2).data, vol)
        one.decode(0)
        assert two.decoded_nodes == one.decoded_nodes
        np.testing.assert_array_equal(
            two.decode(1, "3:30,0:21,9:30", workers=2).data, one.decode(1, "3:30,0:21,9:30").data
        )


@pytest.mark.parametrize("shape, block", [((37, 21, 30), 4), ((5, 70, 33), 4), ((64, 64, 64), 8),
                                          ((3, 3, 3), 2), ((129, 7, 50), 2)])  # fmt: skip
def test_selection_chunks_are_the_union_of_each_nodes(shape, block):
    # a frame's chunks found level by level on grids equal the union of the nodes' own
    # sets, for borders of 0-2 voxels, wider than a block, and one per level
    from volpack.octree.reader import _node_chunks, selection_chunks

    g = layout.Geometry(shape, block)
    rng = np.random.default_rng(sum(shape) + block)
    every = [(lv, b) for lv in range(g.depth + 1) for b in np.ndindex(*g.grid(lv))]
    for n in (0, 1, 7, len(every) // 3, len(every)):
        nodes = [every[i] for i in rng.choice(len(every), n, replace=False)]
        for border in (0, 1, 2, block + 3, lambda lv: 1 if lv > 0 else 0):
            grow = border if callable(border) else (lambda _lv, b=border: b)
            want = set().union(*(_node_chunks(g, lv, b, grow(lv)) for lv, b in nodes))
            assert selection_chunks(g, nodes, border) == want


# -- stability -------------------------------------------------------------------------


def test_region_outside_volume_is_a_clear_error(blob):
    with Octree(blob) as t, pytest.raises(FormatError, match="inside 0:37"):
        t.decode(0, "0:40,0:5,0:5")


def test_level_beyond_root_is_a_clear_error(blob):
    with Octree(blob) as t, pytest.raises(FormatError, match=r"level in 0\.\.4"):
        t.decode(9)


def test_not_an_octree_is_refused():
    from volpack import api

    with pytest.raises(FormatError, match="kind 'octree'"):
        Octree(api.compress_array(np.zeros((4, 4, 4), np.uint8)))


def test_corrupted_node_is_reported_and_the_rest_decodes(vol, blob):
    with Octree(blob) as t:
        key = layout.node_key(1, int(np.ravel_multi_index((2, 1, 1), t.geometry.grid(1))))
        e = t._r._by_key[(0, key)]
    bad = bytearray(blob)
    bad[e.offset + 40] ^= 0xFF
    with Octree(bytes(bad)) as t:
        with pytest.raises(NodeDamaged, match="z 16:24, y 8:16, x 8:16") as ei:
            t.decode(0)
        assert ei.value.level == 1 and ei.value.index == (2, 1, 1)
        np.testing.assert_array_equal(t.decode(0, "0:16,0:21,0:30").data, vol[:16])
        np.testing.assert_array_equal(t.decode(1).data, Octree(blob).decode(1).data)
    with Octree(bytes(bad), on_damage="approximate") as t:
        out = t.decode(0).data
        assert len(t.damaged) == 1 and "z 16:24" in t.damaged[0]["region"]
        ok = np.ones(vol.shape, bool)
        ok[16:24, 8:16, 8:16] = False
        np.testing.assert_array_equal(out[ok], vol[ok])


# -- build: out of core, parallel, Dask ------------------------------------------------


def test_same_bytes_any_worker_count_and_from_files(vol, blob, tmp_path):
    assert _build(vol, block=4, workers=2) == blob
    np.save(tmp_path / "v.npy", vol)
    build(str(tmp_path / "v.npy"), str(tmp_path / "a.vpk"), block=4)
    import h5py
    import tifffile

    with h5py.File(tmp_path / "v.h5", "w") as f:
        f.create_dataset("d", data=vol, chunks=(8, 8, 8))
    build(str(tmp_path / "v.h5") + ":/d", str(tmp_path / "b.vpk"), block=4, workers=2)
    tifffile.imwrite(tmp_path / "v.tif", vol)
    build(str(tmp_path / "v.tif"), str(tmp_path / "c.vpk"), block=4)
    vol.astype(">i2").tofile(tmp_path / "v.raw")
    raw = (("byteorder", ">"), ("dtype", "int16"), ("shape", vol.shape))
    build(SourceSpec(str(tmp_path / "v.raw"), raw), str(tmp_path / "d.vpk"), block=4)
    (tmp_path / "slices").mkdir()
    for i, plane in enumerate(vol):
        tifffile.imwrite(tmp_path / "slices" / f"s{i}.tif", plane)
    build(str(tmp_path / "slices"), str(tmp_path / "e.vpk"), block=4)
    for name in "abcde":
        with Octree(str(tmp_path / f"{name}.vpk")) as t:
            np.testing.assert_array_equal(t.decode(0).data, vol)
            assert t.decode(2).data.tobytes() == Octree(blob).decode(2).data.tobytes()


def test_super_bricks_give_the_same_tree_as_one_task(vol, blob, monkeypatch):
    import importlib

    build_mod = importlib.import_module("volpack.octree.builder")

    monkeypatch.setattr(build_mod, "SUPER_BRICK", 8)  # s = 1: many tasks, deep top
    many = _build(vol, block=4)
    with Octree(many) as a, Octree(blob) as b:
        assert a.plan.sb_levels == 1 and b.plan.sb_levels > 1
        for lv in range(a.depth + 1):
            np.testing.assert_array_equal(a.decode(lv).data, b.decode(lv).data)
            np.testing.assert_array_equal(a.table(lv), b.table(lv))


def test_dask_local_cluster_gives_the_same_bytes(vol, blob):
    need("distributed", "dask")
    from distributed import Client, LocalCluster

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as client,
    ):
        assert _build(vol, block=4, scheduler=client) == blob


# -- command line ----------------------------------------------------------------------


def test_cli_octree_round_trip(vol, tmp_path):
    from click.testing import CliRunner

    from volpack.cli import main

    np.save(tmp_path / "v.npy", vol)
    run = CliRunner().invoke
    r = run(
        main,
        [
            "compress",
            str(tmp_path / "v.npy"),
            str(tmp_path / "v.vpk"),
            "--octree",
            "--block",
            "4",
            "--max-error",
            "2",
            "--json",
        ],
    )
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["max_error"] <= 2
    r = run(main, ["info", str(tmp_path / "v.vpk"), "--levels", "--json"])
    levels = json.loads(r.stdout)["levels"]
    assert [x["level"] for x in levels] == [4, 3, 2, 1, 0]
    r = run(main, ["decompress", str(tmp_path / "v.vpk"), str(tmp_path / "c.npy"), "--level", "2"])
    assert r.exit_code == 0, r.output
    assert np.load(tmp_path / "c.npy").shape == (10, 6, 8)
    r = run(
        main,
        [
            "decompress",
            str(tmp_path / "v.vpk"),
            str(tmp_path / "r.npy"),
            "--roi",
            "0:8,0:8,8:16",
            "--level",
            "1",
        ],
    )
    assert np.load(tmp_path / "r.npy").shape == (4, 4, 4)
    r = run(main, ["decompress", str(tmp_path / "v.vpk"), str(tmp_path / "e.npy"), "--error", "40"])
    assert np.abs(np.load(tmp_path / "e.npy").astype(float) - vol).max() <= 40
    r = run(main, ["decompress", str(tmp_path / "v.vpk"), str(tmp_path / "x.npy"), "--level", "7"])
    assert r.exit_code == 1 and "level in 0..4" in r.output
    r = run(
        main,
        [
            "compress",
            str(tmp_path / "v.npy"),
            str(tmp_path / "q.vpk"),
            "--octree",
            "--quality",
            "63",
        ],
    )
    assert r.exit_code == 2 and "--quality" in r.output


# -- golden files ----------------------------------------------------------------------

GOLDEN = [  # the recipes of scripts/make_examples.py, written out again on purpose
    ("octree-53-arith-i16", "i16", {"block": 4}),
    ("octree-bounded-u8", "u8", {"block": 4, "max_error": 3.0, "coder": "huffman"}),
]


@pytest.mark.parametrize(("stem", "recipe", "opts"), GOLDEN, ids=[g[0] for g in GOLDEN])
def test_golden_octree_decodes_and_is_reproduced(stem, recipe, opts):
    from pathlib import Path

    from volpack.demo import load_demo_volume
    from volpack.format.container import Reader

    cut = load_demo_volume().data[30:50, 40:64, 40:68]
    want = cut if recipe == "u8" else cut.astype(np.int16) * 37 - 3000
    blob = (Path(__file__).parents[2] / "formats" / "examples" / f"{stem}.vpk").read_bytes()
    with Octree(blob) as t:
        got = t.decode(0).data
    assert got.dtype == want.dtype
    assert np.abs(got.astype(np.int64) - want).max() <= opts.get("max_error", 0)
    again = _build(want, **opts)
    with Reader(blob) as old, Reader(again) as new:
        assert old.header == new.header
        assert [(t, n, p) for t, n, p in old] == [(t, n, p) for t, n, p in new]


def test_budget_with_camera_refines_near_the_eye_first():
    from volpack.render.camera import Camera

    a = smooth_volume((32, 32, 32), np.int16, seed=4, noise=30.0)
    with Octree(_build(a, block=4)) as t:
        cam = Camera(azimuth=0, elevation=0, size=(64, 64), projection="perspective", zoom=1.0)
        nodes = sel.by_budget(t, voxels=6000, camera=cam)
        near = [lv for lv, b in nodes if t.geometry.footprint(lv, b)[1].stop <= 16]
        far = [lv for lv, b in nodes if t.geometry.footprint(lv, b)[1].start >= 16]
        assert near and far and np.mean(near) < np.mean(far)  # the eye is at y < 0
        plain = sel.by_budget(t, voxels=6000)
        assert sorted(plain) != sorted(nodes)


def test_axis_weights_equal_the_numpy_steps():
    # resampled()'s per-axis positions, in one kernel, against the numpy form it replaced
    from volpack.octree.resample import axis_weights

    for start, stop, fm, n in [(0, 37, 4, 10), (3, 20, 4, 10), (5, 6, 2, 3), (0, 301, 32, 10),
                               (17, 90, 8, 12), (0, 1, 2, 1), (60, 64, 16, 4)]:  # fmt: skip
        pos = (np.arange(start, stop) + 0.5) / fm - 0.5
        j0 = np.clip(np.floor(pos), 0, n - 1).astype(np.int64)
        j1 = np.minimum(j0 + 1, n - 1)
        w = np.clip(pos - j0, 0.0, 1.0)
        base, a, b, ww = axis_weights(start, stop, fm, n)
        assert base == j0.min() and b.max() + base == j1.max()
        np.testing.assert_array_equal(a + base, j0)
        np.testing.assert_array_equal(b + base, j1)
        assert ww.tobytes() == w.tobytes()  # bit for bit, signs of zeros included


def test_reading_an_integer_tree_imports_no_codec_it_does_not_use(tmp_path):
    # an integer tree stores no codec: opening it and decoding its levels needs neither
    # the codec registry, nor the lossy codec, nor the entropy coders other than its own
    # (they were 50-65 ms of a walk's start), nor the builder (10 ms)
    import subprocess
    import sys

    path = tmp_path / "t.vpk"
    build((np.arange(40**3) % 251).astype(np.uint8).reshape(40, 40, 40), path)
    code = (
        "import sys; import numpy as np; from volpack.octree import Octree\n"
        "with Octree(sys.argv[1]) as t:\n"
        "    assert t.decode(0).data.shape == (40, 40, 40)\n"
        "print(' '.join(m for m in sys.modules if m.startswith('volpack.')))"
    )
    out = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True,
                         text=True, check=True).stdout.split()  # fmt: skip
    assert "volpack.entropy.arith" in out  # the tree's coder: the check can fail
    for unused in ("volpack.volume_codec.registry", "volpack.volume_codec.lossy",
                   "volpack.entropy.arith2", "volpack.entropy.static",
                   "volpack.octree.builder", "volpack.metrics"):  # fmt: skip
        assert unused not in out


def test_octree_build_stays_the_function_once_the_builder_is_imported():
    # the package hands out build() on first use; importing the builder module (as
    # octree.stream does) must not put the module in its place
    import subprocess
    import sys

    code = (
        "import volpack.octree as o, volpack.octree.builder as b, volpack.octree.stream\n"
        "from volpack.octree import build\n"
        "assert build is b.build and o.build is b.build and callable(build), build\n"
        "from volpack.octree import *\n"
        "try:\n"
        "    o.nothing\n"
        "except AttributeError:\n"
        "    print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["ok"]
