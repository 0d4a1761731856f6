"""Level-of-detail rendering of octrees: the paged sampler against the plain ray caster,
budgets, caches across a walkthrough, and the render/walk commands."""

from __future__ import annotations

import json
import threading

import numpy as np
import pytest
from click.testing import CliRunner

from volpack.cli import main
from volpack.demo import load_demo_volume
from volpack.octree import Octree, build, select
from volpack.render.camera import Camera
from volpack.errors import VolpackError
from volpack.render.lod import NodeAtlas, paged_volume, render_lod
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import brick_ranges, brick_size, render
from volpack.render.transfer import load_tf


@pytest.fixture(scope="module")
def tree_path(tmp_path_factory):
    vol = load_demo_volume().data[10:58, 20:100, 16:112]  # 48 x 80 x 96, not a power of two
    path = tmp_path_factory.mktemp("lod") / "brain.vpk"
    build(vol, str(path), block=8)
    return path, vol


def tf_of(vol):
    return load_tf("auto", float(vol.min()), float(vol.max()), dtype=vol.dtype)


# The paged sampler's exact-normal march, compiled for this test alone: slow set (the
# resident walk's test below compares the paged sampler's image in the fast set).
@pytest.mark.slow
@pytest.mark.parametrize("grads", [False, True])
@pytest.mark.parametrize("cls", ["post", "preintegrated"])
def test_full_resolution_selection_renders_exactly_like_the_volume(tree_path, cls, grads):
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    cam = Camera(size=(40, 36), azimuth=35, elevation=25, projection="perspective")
    kw = dict(tf=tf_of(vol), camera=cam, value_range=vr, classification=cls, shading="phong")
    with Octree(str(path)) as t:
        # with gradient bricks (central differences of each node grown by two voxels)
        # or differences taken on the fly through the page table
        pv = paged_volume(t, select.by_level(t, 0), gradients=grads)
        assert (pv.grad is not None) == grads and pv.atlas.dtype == vol.dtype
        # the plain volume takes the fast path (raycast._march) with precomputed
        # gradients: the same samples and sums, rounded differently
        np.testing.assert_allclose(render(pv, **kw), render(vol, **kw), atol=1e-5)


# the page table's march variants with and without skipping are its own (about 10 CPU s of
# compiling each); the full-resolution test above keeps the paged path in the fast set
@pytest.mark.slow
@pytest.mark.parametrize("cls", ["post", "preintegrated"])
def test_empty_space_skipping_through_the_page_table_leaves_the_image_unchanged(tree_path, cls):
    # a mixed-resolution selection: bricks are judged by the value range of the node
    # voxels their samples read, so skipping them must not change a pixel
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    cam = Camera(size=(48, 40), azimuth=60, elevation=15)
    kw = dict(tf=tf_of(vol), camera=cam, value_range=vr, classification=cls, shading="phong")
    with Octree(str(path)) as t:
        sel, _ = select.by_view(t, cam, tf=kw["tf"], voxels=12 * 8**3)
        pv = paged_volume(t, sel)
        assert len({lv for lv, _ in sel}) > 1
        a, sa = render(pv, skip_empty=False, render_stats=True, **kw)
        b, sb = render(pv, skip_empty=True, render_stats=True, **kw)
    np.testing.assert_array_equal(a, b)
    assert sb.samples < sa.samples


@pytest.mark.slow
def test_budget_bounds_the_nodes_and_more_nodes_cost_less_error(tree_path):
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    cam = Camera(size=(64, 64), azimuth=30, elevation=20, zoom=1.5)
    tf = tf_of(vol)
    ref = render(vol, tf=tf, camera=cam, value_range=vr)
    errs = []
    with Octree(str(path)) as t:
        for blocks in (4, 16, 128, 4096):  # 4: the top level has 4 nodes
            img, st = render_lod(t, tf=tf, camera=cam, blocks=blocks, value_range=vr)
            assert st.nodes >= 1 and st.voxels <= blocks * 8**3
            errs.append(float(np.sqrt(np.mean((img - ref) ** 2))))
        assert errs[-1] < 0.5 * errs[0], errs
        # the same view again decodes nothing: every node is in the cache
        _, st = render_lod(t, tf=tf, camera=cam, blocks=4096, value_range=vr)
        assert st.decoded == 0
        # a walkthrough that enters the volume and leaves it again; the bricks kept
        # from frame to frame give the atlas a fresh assembly gives (the paged sampler:
        # the resident volume has tests of its own below)
        atlas = NodeAtlas(t, resident_budget=0)
        most = 0
        for dist in (300.0, 20.0, 0.0, 20.0, 300.0):
            cam_w = Camera(size=(16, 16), projection="perspective", distance=dist, azimuth=dist)
            img, st = render_lod(t, tf=tf, camera=cam_w, blocks=64, value_range=vr)
            kept, _ = render_lod(t, tf=tf, camera=cam_w, blocks=64, value_range=vr,
                                 atlas=atlas)  # fmt: skip
            most = max(most, st.nodes)
            assert np.array_equal(img, kept) and st.nodes <= len(atlas.slot)
            assert len(atlas.atlas) <= 2 * most  # slots: at most keep (2) x the selection
            assert np.all(np.isfinite(img)) and st.nodes >= 1
            if dist == 0.0:  # inside: every ray starts in the volume
                assert (img[..., 3] > 0).mean() > 0.5
        # a camera looking away from the volume (from inside, facing out) draws nothing odd
        away = Camera(size=(16, 16), projection="perspective", distance=0.0, elevation=-89)
        img, st = render_lod(t, tf=tf, camera=away, blocks=64, value_range=vr)
        assert np.all(np.isfinite(img))


@pytest.mark.slow  # the atlas's normal-code march: a kernel of its own
def test_node_atlas_reuses_slots_and_bounds_gradient_memory(tree_path):
    # an orbit through views that need different nodes, with no spare slots (keep=1):
    # slots are reused, each frame equals a fresh assembly, and a gradient budget too
    # small for the bricks falls back to differences on the fly (the same image as
    # rendering without them)
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    tf = tf_of(vol)
    with Octree(str(path)) as t:
        atlas = NodeAtlas(t, keep=1.0)
        starved = NodeAtlas(t, gradient_budget=0)
        placed = []
        most = 0
        for az in (0.0, 90.0, 180.0, 270.0, 0.0):
            cam = Camera(size=(24, 20), azimuth=az, zoom=3.0)
            kw = dict(tf=tf, camera=cam, value_range=vr, shading="phong")
            sel, _ = select.by_view(t, cam, tf=tf, voxels=24 * 8**3)
            fresh = render(paged_volume(t, sel, gradients=True), **kw)
            np.testing.assert_array_equal(render(atlas.paged(sel), **kw), fresh)
            most = max(most, len(sel))
            assert len(atlas.atlas) <= most  # keep=1: no more slots than one view needs
            placed.append(atlas.placed)
            assert atlas.codes.nbytes == 2 * atlas.atlas.size  # quantised normals: 2 B a voxel
            assert atlas.nbytes == atlas.atlas.nbytes + atlas.grad.nbytes + atlas.codes.nbytes
            pv = starved.paged(sel)
            assert pv.grad is None and pv.codes is None
            np.testing.assert_array_equal(render(pv, **kw),
                                          render(paged_volume(t, sel), **kw))  # fmt: skip
        assert placed[-1] > placed[0]  # the views needed new nodes ...
        assert placed[-1] < 5 * placed[0]  # ... not all of them each time


def _resident_walk(t, cams, tf, vr, blocks, **kw):
    """Each view of a walk drawn three ways: by one resident volume kept across the
    frames, by a fresh one, and by the paged sampler kept across the frames."""
    kept, paged = NodeAtlas(t), NodeAtlas(t, resident_budget=0)
    for cam in cams:
        a = dict(tf=tf, camera=cam, value_range=vr, blocks=blocks, **kw)
        img, st = render_lod(t, atlas=kept, **a)
        fresh, _ = render_lod(t, atlas=NodeAtlas(t), **a)
        yield img, fresh, render_lod(t, atlas=paged, **a)[0], st, kept


# slow: the paged sampler's march and the uint8 unshaded one are this test's alone (21 CPU s
# of compiling); the walk commands' test below runs the resident grid in the fast set
@pytest.mark.slow
def test_resident_walk_matches_a_fresh_grid_and_the_paged_sampler(tree_path):
    # an orbit whose selection changes between frames (a budget of 24 nodes over three
    # levels): the grid rewritten only where the selection changed gives the image a
    # grid written whole gives, and differs from the paged sampler (coarse nodes
    # sampled at their own resolution) by an RMSE under 0.02 (the LOD error against
    # the full volume is 0.1-0.2 RMSE here); at full resolution it is the plain image
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    tf = tf_of(vol)
    cams = [Camera(size=(32, 28), azimuth=az, zoom=1.5) for az in (0.0, 50.0, 100.0)]
    with Octree(str(path)) as t:
        written, sels = [], set()
        for img, fresh, paged, st, kept in _resident_walk(t, cams, tf, vr, 24, shading="phong"):
            np.testing.assert_array_equal(img, fresh)
            assert float(np.sqrt(np.mean((img - paged) ** 2))) < 0.02
            assert len(st.levels) > 1 and kept.resident is not None and not kept.slot
            written.append(kept.resident.written)
            # brick ranges kept from the grid's one value and the boxes written since:
            # those of the grid read whole
            prep, b = kept.resident.prep, brick_size(vol.shape)
            for have, want in zip(prep.brick_ranges(None, b, brick_ranges),
                                  prepare_volume(prep.data).brick_ranges(None, b, brick_ranges)):  # fmt: skip
                np.testing.assert_array_equal(have, want)
            sels.add(tuple(sorted(st.levels.items())))
        assert len(sels) > 1 and written[0] < written[-1] < 3 * written[0]
        cam = Camera(size=(64, 64), azimuth=50.0, zoom=1.5)  # enough pixels for level 0
        img, st = render_lod(t, tf=tf, camera=cam, value_range=vr, blocks=4096, atlas=kept)
        assert st.levels[0] > 0.9 * st.nodes
        np.testing.assert_array_equal(img, render(vol, tf=tf, camera=cam, value_range=vr))


def test_decode_budget_starts_coarse_and_reaches_the_uncapped_image(tree_path):
    # a walk capped at CAP decoded chunks a frame, from an empty cache: its first frame
    # decodes at most CAP and draws coarser nodes than the uncapped first frame (a
    # frame's first refinement may pass the cap: here one takes 18); held back
    # refinements go on over the next frames, and once none is held back the frame is
    # the uncapped walk's last frame, bit for bit
    cap = 6
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    tf = tf_of(vol)
    cams = [Camera(size=(32, 28), azimuth=az, zoom=1.5) for az in (0.0, 50.0, 100.0)]
    kw = dict(tf=tf, value_range=vr, blocks=24, shading="phong")
    with Octree(str(path)) as t:
        free = NodeAtlas(t)
        uncapped = [render_lod(t, camera=cam, atlas=free, **kw) for cam in cams]
    assert uncapped[0][1].decoded > 2 * cap
    with Octree(str(path)) as t:
        capped, frames = NodeAtlas(t), []
        for k in range(16):  # the orbit, then its last view until nothing is held back
            frames.append(render_lod(t, camera=cams[min(k, 2)], atlas=capped, decode=cap, **kw))
            if k >= 2 and frames[-1][1].held == 0:
                break
    first = frames[0][1]
    assert first.decoded <= cap and first.held > 0
    assert min(first.levels) > min(uncapped[0][1].levels)
    # only chunks that the uncapped views decode too (refinements in the same order)
    assert sum(st.decoded for _, st in frames) <= sum(st.decoded for _, st in uncapped)
    img, st = frames[-1]
    assert st.held == 0 and st.levels == uncapped[-1][1].levels
    np.testing.assert_array_equal(img, uncapped[-1][0])


@pytest.mark.parametrize("lift", [0, 3])
def test_reserved_grid_and_codes_give_the_same_walk(tree_path, lift):
    # a walk whose first frame's grid and normal codes were made beforehand on a helper
    # thread (NodeAtlas.reserve) draws every frame as the walk that makes them in the
    # frame; one worker reserves nothing. The empty cells' value is 0 (the zeroed grid
    # kept as it is) or, with the range's low end lifted, not (the grid filled)
    path, vol = tree_path
    vr = (float(vol.min()) + lift, float(vol.max()))
    cams = [Camera(size=(32, 28), azimuth=az, zoom=1.5) for az in (0.0, 50.0, 100.0)]
    kw = dict(tf=tf_of(vol), value_range=vr, blocks=24, shading="phong", workers=2)
    with Octree(str(path)) as t:
        one = NodeAtlas(t)
        one.reserve(vr, codes=True, workers=1)
        assert one.resident is None
        kept = NodeAtlas(t)
        kept.reserve(vr, codes=True, workers=2)
        assert kept.resident.reserved is not None
        frames = [render_lod(t, camera=cam, atlas=kept, **kw) for cam in cams]
        prep = kept.resident.prep
        assert kept.resident.reserved is None and prep.codes_out is None  # both taken
        assert (kept.resident.fill == 0) == (lift == 0)
    with Octree(str(path)) as t:
        made = NodeAtlas(t)
        ref = [render_lod(t, camera=cam, atlas=made, **kw) for cam in cams]
    for (img, st), (want, wst) in zip(frames, ref):
        np.testing.assert_array_equal(img, want)
        assert st.levels == wst.levels
    np.testing.assert_array_equal(prep.data, made.resident.prep.data)
    np.testing.assert_array_equal(prep.normal_codes(None, prep.spacing).codes,
                                  made.resident.prep.normal_codes(None, prep.spacing).codes)  # fmt: skip


def test_a_rehearsed_walk_draws_what_an_unrehearsed_one_draws(tree_path):
    # the first frame rehearsed on a helper thread (render.rehearse: chunk scans, energy
    # bounds, the write and render kernels loaded, never compiled) changes no frame;
    # one worker rehearses nothing
    from volpack.render.rehearse import rehearse

    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    cams = [Camera(size=(32, 28), azimuth=az, zoom=1.5) for az in (0.0, 50.0, 100.0)]
    opts = dict(shading="phong", workers=2)
    kw = dict(tf=tf_of(vol), value_range=vr, blocks=24, **opts)
    with Octree(str(path)) as t:
        made = NodeAtlas(t)
        ref = [render_lod(t, camera=cam, atlas=made, **kw) for cam in cams]
    with Octree(str(path)) as t:
        assert rehearse(NodeAtlas(t), vr, opts, False, 1) is None
        atlas = NodeAtlas(t)
        r = rehearse(atlas, vr, opts, False, 2)
        r.wait()  # the kernels the walk above ran are loaded: every step runs
        assert r.done == ["scans", "writes", "render"] and not r.skipped
        frames = [render_lod(t, camera=cam, atlas=atlas, **kw) for cam in cams]
    for (img, st), (want, wst) in zip(frames, ref):
        np.testing.assert_array_equal(img, want)
        assert st.levels == wst.levels and st.decoded == wst.decoded


def test_walk_pauses_the_collector_until_its_first_frame(tree_path, tmp_path, monkeypatch):
    # from its imports to its first frame a walk makes objects, not garbage: the cycle
    # collector is paused (on every thread) and runs again from the first frame on
    import gc

    from volpack.render import autotf, lod

    path, _ = tree_path
    seen = {"phase": "start", "paused": [], "runs": []}
    gc.callbacks.append(cb := lambda phase, info: seen["runs"].append(seen["phase"]))
    pick, draw = autotf.transfer_for, lod.render_lod

    def transfer_for(*a, **k):  # before the first frame: many container objects
        seen["phase"] = "before the first frame"
        seen["paused"].append(gc.isenabled())
        junk = [[i] for i in range(50_000)]  # noqa: F841
        try:
            return pick(*a, **k)
        finally:
            seen["phase"] = "after the TF"

    def render_lod(*a, **k):
        seen["phase"] = "frames"
        seen["paused"].append(gc.isenabled())
        junk = [[i] for i in range(50_000)]  # noqa: F841
        return draw(*a, **k)

    monkeypatch.setattr(autotf, "transfer_for", transfer_for)
    monkeypatch.setattr(lod, "render_lod", render_lod)
    try:
        r = CliRunner().invoke(main, ["walk", str(path), "--orbit", "2", "--budget", "8",
                                      "--size", "16x16", "-j", "2"])  # fmt: skip
    finally:
        gc.callbacks.remove(cb)
    assert r.exit_code == 0, r.output
    assert seen["paused"] == [False, True, True] and gc.isenabled()
    assert "before the first frame" not in seen["runs"] and "frames" in seen["runs"]


def test_reserved_arrays_are_zeroed_and_taken_once():
    from volpack.render.resident import Reserved

    r = Reserved({"grid": ((5, 6, 7), np.uint8), "codes": ((5, 6, 7), np.uint16)})
    assert r.take("codes", (5, 6, 8), np.uint16) is None  # another shape: not handed out
    g = r.take("grid", (5, 6, 7), np.uint8)
    assert g.shape == (5, 6, 7) and g.dtype == np.uint8 and not g.any()
    assert r.take("grid", (5, 6, 7), np.uint8) is None  # once


@pytest.mark.slow  # the paged sampler's own kernels; its image equality is in the fast set too
def test_resident_volume_over_its_budget_walks_paged(tree_path):
    # a budget below the grid's bytes: every frame goes through the page table
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    tf = tf_of(vol)
    cam = Camera(size=(24, 20), azimuth=20)
    with Octree(str(path)) as t:
        small = NodeAtlas(t, resident_budget=vol.size * 3 - 1)
        img, _ = render_lod(t, tf=tf, camera=cam, value_range=vr, blocks=24, atlas=small)
        ref, _ = render_lod(t, tf=tf, camera=cam, value_range=vr, blocks=24,
                            atlas=NodeAtlas(t, resident_budget=0))  # fmt: skip
        assert small.resident is None and small.slot
        np.testing.assert_array_equal(img, ref)
        with pytest.raises(VolpackError, match="resident budget"):
            NodeAtlas(t, resident_budget=-1)


@pytest.mark.slow
def test_resident_walk_into_the_volume_keeps_gradients_and_normals_exact(tree_path):
    # a perspective walk that enters the volume and leaves it (gradients, rewritten
    # box by box) and an orthographic one lit by quantised normals, post-classified and
    # pre-classified (which the paged sampler does not draw): the kept grid's image is
    # the fresh grid's, bit for bit, and near the paged sampler's
    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    tf = tf_of(vol)
    inside = [Camera(size=(24, 24), projection="perspective", distance=d, azimuth=d)
              for d in (300.0, 20.0, 0.0, 20.0, 300.0)]  # fmt: skip
    orbit = [Camera(size=(24, 24), azimuth=az, elevation=30) for az in (0.0, 120.0, 240.0, 0.0)]
    with Octree(str(path)) as t:
        for cams, kw in ((inside, {"shading": "phong"}),
                         (orbit, {"shading": "phong", "classification": "post"}),
                         (orbit, {"shading": "none", "classification": "post"})):  # fmt: skip
            for img, fresh, paged, _, _ in _resident_walk(t, cams, tf, vr, 48, **kw):
                np.testing.assert_array_equal(img, fresh)
                assert np.all(np.isfinite(img))
                assert float(np.sqrt(np.mean((img - paged) ** 2))) < 0.03
        kept = NodeAtlas(t)
        for cam in orbit:
            img, _ = render_lod(t, tf=tf, camera=cam, value_range=vr, blocks=48, atlas=kept,
                                classification="pre")  # fmt: skip
            fresh, _ = render_lod(t, tf=tf, camera=cam, value_range=vr, blocks=48,
                                  atlas=NodeAtlas(t), classification="pre")  # fmt: skip
            np.testing.assert_array_equal(img, fresh)


@pytest.mark.slow  # a uint8 Phong march of its own (9.5 CPU s to compile) that no other fast test needs
def test_render_and_walk_commands(tree_path, tmp_path):
    from PIL import Image

    path, vol = tree_path
    run = CliRunner().invoke
    r = run(main, ["render", str(path), str(tmp_path / "a.png"), "--budget", "32",
                   "--size", "48x40", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["lod"][0]["voxels"] <= 32 * 8**3
    with Image.open(tmp_path / "a.png") as im:
        assert im.size == (48, 40)
    r = run(
        main,
        [
            "walk",
            str(path),
            str(tmp_path / "w.gif"),
            "--orbit",
            "3",
            "--budget",
            "16",
            "--size",
            "32x32",
            "--compare",
            "--json",
            "--perspective",
            "--distance",
            "30",
            "--tf",
            "mri",
            "--decode-budget",
            "5",
        ],
    )  # fmt: skip (the PSNR bound is for mri)
    assert r.exit_code == 0, r.output
    rep = json.loads(r.stdout)
    assert rep["frames"] == 3 and all(f["voxels"] <= 16 * 8**3 for f in rep["per_frame"])
    assert rep["decode_budget"] == 5 and all(f["decoded"] <= 5 for f in rep["per_frame"])
    assert all(f["held"] >= 0 for f in rep["per_frame"])
    assert all(f["psnr"] is None or f["psnr"] > 15 for f in rep["per_frame"])
    done = [f["finished_at"] for f in rep["per_frame"]]  # seconds since the process started
    assert done == sorted(done) and done[0] > 0
    with Image.open(tmp_path / "w.gif") as im:
        assert im.n_frames == 3
    r = run(main, ["render", str(tmp_path / "a.png"), str(tmp_path / "b.png"), "--budget", "3"])
    assert r.exit_code != 0 and "octree" in r.output


# both compile the atlas's Phong march for themselves: slow set (a one-voxel-thick plain
# volume stays in the fast set: test_render.py)
@pytest.mark.slow
@pytest.mark.parametrize("kind", ["uint16 full range", "one voxel thick"])
def test_gradient_bricks_match_the_plain_volume_on_16_bit_and_thin_volumes(tmp_path, kind):
    # full-range uint16 needs float32 gradient bricks (differences pass int16); a volume
    # one voxel thick has nodes that are all border; anisotropic spacing, a camera
    # inside the volume, and a clear and an opaque TF besides a semi-transparent one
    rng = np.random.default_rng(3)
    if kind == "one voxel thick":
        vol = rng.integers(0, 255, (1, 13, 14)).astype(np.uint8)
    else:
        vol = rng.integers(0, 65535, (12, 13, 14)).astype(np.uint16)
    build(vol, str(tmp_path / "v.vpk"), block=4)
    tabs = [np.array([[0, 0, 0, 0], [1, 0.5, 0.2, 0.3], [1, 1, 1, 0.6]]), np.zeros((2, 4)),
            np.ones((2, 4))]  # fmt: skip
    with Octree(str(tmp_path / "v.vpk")) as t:
        pv = paged_volume(t, select.by_level(t, 0), gradients=True)
        assert pv.grad.dtype == (np.float32 if vol.dtype == np.uint16 else np.int16)
        for tab in tabs:
            for cam in (Camera(size=(20, 18), azimuth=30, elevation=20),
                        Camera(size=(20, 18), projection="perspective", distance=0.0)):  # fmt: skip
                kw = dict(tf=tab, camera=cam, shading="phong", spacing=(2.0, 1.0, 0.7),
                          value_range=(float(vol.min()), float(vol.max())))  # fmt: skip
                for normals in ("exact", "quantised"):  # gradient bricks, code bricks
                    kwn = dict(kw, normals=normals)
                    if normals == "quantised":  # code bricks hold the tree's spacing
                        kwn.pop("spacing")
                    img = render(pv, **kwn)
                    assert np.all(np.isfinite(img))
                    np.testing.assert_allclose(img, render(vol, **kwn), atol=1e-6)


def test_cell_boxes_cover_the_marked_cells_once_with_few_boxes():
    from volpack.render.resident import cell_boxes

    rng = np.random.default_rng(3)
    shape = (37, 50, 21)  # cells of 4 voxels: 10 x 13 x 6, edge cells cut
    for p in (0.0, 0.3, 0.9, 1.0):
        cells = rng.random((10, 13, 6)) < p
        cells[:4, :4, :4] = True  # one aligned block of 4^3 cells: one box
        cover = np.zeros(shape, np.int64)
        boxes = cell_boxes(cells, 4, shape)
        for b in boxes:
            cover[b] += 1
        want = cells.repeat(4, 0).repeat(4, 1).repeat(4, 2)[:37, :50, :21]
        np.testing.assert_array_equal(cover, want.astype(np.int64))
        assert len(boxes) <= cells.sum() - 63
    assert len(cell_boxes(np.ones((10, 13, 6), bool), 4, shape)) == 1


def _two_levels(t, split: int):
    """Every level-1 node of ``t``, the first ``split`` replaced by their level-0 children."""
    g = t.geometry
    ones = [(1, b) for b in np.ndindex(*g.grid(1))]
    kids = [(0, (2 * z + i, 2 * y + j, 2 * x + k)) for (_, (z, y, x)) in ones[:split]
            for i, j, k in np.ndindex(2, 2, 2)
            if 2 * z + i < g.grid(0)[0] and 2 * y + j < g.grid(0)[1] and 2 * x + k < g.grid(0)[2]]  # fmt: skip
    return kids + ones[split:]


def test_resident_writes_a_level_while_a_helper_decodes_the_next_ones_chunks(tree_path, monkeypatch):
    # two workers: the coarse level's chunks first on both, then this thread writes that
    # level's boxes while a helper ("volpack-decode") decodes the chunks the finer
    # level's nodes need, when they are many (a first frame; a few are decoded with the
    # rest first, as a later frame's); the grid is the one-worker grid, byte for byte
    from volpack.octree.reader import Octree as Reader
    from volpack.render.resident import BESIDE, ResidentVolume

    path, vol = tree_path
    vr = (float(vol.min()), float(vol.max()))
    seen = []
    children = Reader._children

    def spy(self, level, index):
        hit = (level, index) in self._cache
        if not hit:
            seen.append((threading.current_thread().name, level))
        return children(self, level, index)

    monkeypatch.setattr(Reader, "_children", spy)
    for split, many in ((40, True), (1, False)):
        grids = []
        for workers in (1, 2):
            seen.clear()
            with Octree(str(path)) as t:
                rv = ResidentVolume(t, vr)
                grids.append(rv.update(_two_levels(t, split), 0.0, workers).data.copy())
        finer = sum(lv == 1 for _, lv in seen)  # level-1 chunks give the level-0 voxels
        assert (finer >= BESIDE) == many, finer
        helper = {lv for name, lv in seen if name == "volpack-decode"}
        assert helper == ({1} if many else set()), seen
        assert {lv for name, lv in seen if name != "volpack-decode"} >= {2}
        np.testing.assert_array_equal(grids[1], grids[0])


def test_resident_write_levels_raise_the_helpers_error(tree_path, monkeypatch):
    # a chunk the helper cannot decode fails the frame as it would on one worker
    from volpack.errors import FormatError
    from volpack.octree.reader import Octree as Reader
    from volpack.render.resident import ResidentVolume

    path, vol = tree_path
    children = Reader._children

    def damaged(self, level, index):
        if level == 1 and (level, index) not in self._cache:
            raise FormatError("damaged chunk")
        return children(self, level, index)

    monkeypatch.setattr(Reader, "_children", damaged)
    for workers in (1, 2):
        with Octree(str(path)) as t, pytest.raises(FormatError, match="damaged chunk"):
            ResidentVolume(t, (float(vol.min()), float(vol.max()))).update(_two_levels(t, 40), 0.0,
                                                                           workers)
