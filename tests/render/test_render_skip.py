"""Empty-space skipping in the ray caster (volpack.render.raycast): the signed leap map
against brute-force distances, images with and without skipping on the fast path in the
cases where a renderer breaks, the brick size, and what a PreparedVolume keeps across
frames (the empty-brick mask and the leap map) following the transfer function."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import volpack.render.raycast as rc
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction


def brute_leap(empty: np.ndarray) -> np.ndarray:
    """The leap map by definition: Chebyshev distance to the nearest brick of the other
    kind, positive on empty bricks, negative on visible ones (``big`` where none)."""
    big = sum(empty.shape) + 1
    out = np.zeros(empty.shape, np.int64)
    idx = np.argwhere(np.ones(empty.shape, bool))
    for p in idx:
        other = idx[empty.ravel() != empty[tuple(p)]]
        d = big if len(other) == 0 else int(np.abs(other - p).max(axis=1).min())
        out[tuple(p)] = d if empty[tuple(p)] else -d
    return out


@pytest.mark.parametrize("seed, fill", [(0, 0.3), (1, 0.7), (2, 0.95), (3, 0.0), (4, 1.0)])
def test_leap_map_is_the_signed_chebyshev_distance(seed, fill):
    empty = np.random.default_rng(seed).random((5, 7, 6)) < fill
    leap = np.zeros(empty.shape, np.int32)
    rc._leap_kernel(empty, leap)
    np.testing.assert_array_equal(leap, brute_leap(empty))


def blobs(shape=(40, 44, 36), seed=0) -> np.ndarray:
    """A few solid balls with holes in empty surroundings: empty and visible regions of
    many bricks each, so rays leap over both kinds."""
    r = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in shape), indexing="ij")
    vol = np.zeros(shape)
    for _ in range(4):
        c = r.uniform(0.2, 0.8, 3) * np.array(shape)
        rad = r.uniform(5, 11)
        d = np.sqrt((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2)
        vol = np.maximum(vol, np.clip(1.2 - d / rad, 0, 1))
    vol[shape[0] // 2 - 2: shape[0] // 2 + 2] *= 0.2  # a dim slab through them
    return vol


TF = TransferFunction(points=((0.25, 0, 0, 0, 0.0), (0.5, 0.9, 0.6, 0.4, 0.08),
                              (1.0, 1.0, 1.0, 1.0, 0.3)))  # fmt: skip
CAMERAS = [
    Camera(azimuth=35, elevation=25, size=(32, 30)),
    Camera(azimuth=0, elevation=0, size=(24, 24)),  # along the axes: rays on brick faces
    Camera(azimuth=20, elevation=10, distance=2.0, projection="perspective", size=(24, 24)),
    Camera(azimuth=200, elevation=-30, distance=0.0, size=(24, 24)),  # inside
]


@pytest.mark.parametrize("cls, shading", [
    ("post", "none"), ("preintegrated", "none"),
    pytest.param("post", "phong", marks=pytest.mark.slow),  # float32 Phong marches
    pytest.param("preintegrated", "phong", marks=pytest.mark.slow),
])  # fmt: skip
def test_skipping_leaves_the_fast_path_image_unchanged(cls, shading):
    vol = blobs()
    kw = dict(tf=TF, classification=cls, shading=shading, step=0.7)
    for cam, sp in itertools.product(CAMERAS, [(1, 1, 1), (2.2, 1.0, 0.6)]):
        a, sa = render(vol, spacing=sp, camera=cam, skip_empty=False, render_stats=True, **kw)
        b, sb = render(vol, spacing=sp, camera=cam, skip_empty=True, render_stats=True, **kw)
        np.testing.assert_allclose(a, b, atol=1e-6)
        if a[..., 3].max() > 0:
            assert sb.samples < sa.samples
    # one voxel thick, edge-on and at a slant
    for el in (0, 40):
        cam = Camera(azimuth=15, elevation=el, size=(20, 20))
        a = render(vol[20:21], camera=cam, skip_empty=False, **kw)
        b = render(vol[20:21], camera=cam, skip_empty=True, **kw)
        np.testing.assert_allclose(a, b, atol=1e-6)


def test_brick_size_keeps_the_maps_bounded_and_the_image(monkeypatch):
    # small volumes skip by 4^3 bricks too (session 36: 2^3 bricks doubled the tests a
    # ray and cost more than the samples they saved, results/render/rend36)
    assert rc.brick_size((1, 1, 1)) == rc.brick_size((64, 64, 64)) == rc.FINE_BRICK
    assert rc.brick_size((65, 64, 64)) == rc.brick_size((256, 256, 256)) == rc.FINE_BRICK
    assert rc.brick_size((1024, 1024, 1024)) == rc.BRICK
    nb = -(-np.array((1024, 1024, 1024)) // rc.BRICK)
    assert nb.prod() * 12 < 32 << 20  # ranges (8 bytes) + leap map (4) a brick
    vol = blobs()
    assert rc.brick_size(vol.shape) == rc.FINE_BRICK
    kw = dict(tf=TF, camera=CAMERAS[0], shading="phong")
    fine, s4 = render(vol, render_stats=True, **kw)
    monkeypatch.setattr(rc, "FINE_BRICKS", 0)
    coarse, s8 = render(vol, render_stats=True, **kw)
    np.testing.assert_allclose(fine, coarse, atol=1e-6)
    assert s4.samples < s8.samples


def test_a_prepared_volume_follows_the_transfer_function():
    vol = blobs()
    prep = prepare_volume(vol)
    low = TransferFunction(points=((0.1, 0.2, 0.9, 0.2, 0.0), (0.3, 0.2, 0.9, 0.2, 0.05),
                                   (0.45, 0, 0, 0, 0.0)))  # fmt: skip
    runs = [(TF, "post", 0.7), (low, "post", 0.7), (TF, "preintegrated", 0.5),
            (low, "preintegrated", 0.5), (TF, "post", 0.7)]  # fmt: skip
    for az in (30, 60):
        for tf, cls, step in runs:
            kw = dict(tf=tf, classification=cls, step=step,
                      camera=Camera(azimuth=az, elevation=20, size=(28, 28)))  # fmt: skip
            kept = render(prep, **kw)
            fresh = render(vol, **kw)
            assert kept[..., 3].max() > 0.05
            np.testing.assert_array_equal(kept, fresh)


@pytest.mark.parametrize("shape, brick, workers, nan, dtype", [((9, 13, 8), 4, 1, False, "f4"),
                                                               ((17, 5, 11), 4, 3, False, "f4"),
                                                               ((12, 9, 20), 8, 2, False, "f4"),
                                                               ((9, 6, 13), 4, 1, True, "f4"),
                                                               ((9, 13, 8), 4, 1, False, "u1"),
                                                               ((17, 5, 11), 2, 3, False, "i2"),
                                                               ((1, 6, 1), 4, 1, False, "i2")])  # fmt: skip
def test_brick_ranges_hold_each_brick_and_its_overlap_voxel(shape, brick, workers, nan, dtype,
                                                            monkeypatch):  # fmt: skip
    # integer volumes take their own kernel (planes, then rows, then bricks)
    monkeypatch.setattr(rc, "SMALL_RANGES", 0)  # the threads' slabs too, on a small volume
    rng = np.random.default_rng(sum(shape))
    if dtype == "f4":
        vol = rng.normal(size=shape).astype(np.float32)
    else:
        info = np.iinfo(dtype)
        vol = rng.integers(info.min, info.max, shape, endpoint=True).astype(dtype)
    if nan:  # NaN voxels are skipped, a row's first voxel among them
        vol[rng.random(shape) < 0.3] = np.nan
        vol[:, :, ::brick] = np.nan
        vol[0, 0, :] = np.nan
    nb = tuple(-(-n // brick) for n in shape)
    mins, maxs = np.empty(nb, np.float32), np.empty(nb, np.float32)
    rc.brick_ranges(vol, brick, mins, maxs, workers)
    for b in itertools.product(*(range(n) for n in nb)):
        part = vol[tuple(slice(i * brick, (i + 1) * brick + 1) for i in b)]
        part = part[np.isfinite(part)]
        assert (mins[b], maxs[b]) == ((part.min(), part.max()) if part.size else (np.inf, -np.inf))


@pytest.mark.slow  # a uint8 Phong march of its own (9.5 CPU s to compile) that no other fast test needs
def test_a_rewritten_prepared_volume_draws_what_a_fresh_one_draws():
    # a walk's resident volume rewrites boxes of its data between frames and tells the
    # PreparedVolume (PreparedVolume.rewritten): the brick ranges, the empty bricks,
    # the gradients (perspective) and the quantised normals (orthographic) it keeps
    # must then be those of the new data, also next to the boxes and at the edges
    vol = (blobs() * 255).astype(np.uint8)
    prep = prepare_volume(vol.copy())
    cams = [Camera(azimuth=35, elevation=25, size=(30, 28)),
            Camera(projection="perspective", distance=60.0, azimuth=120, size=(30, 28))]  # fmt: skip
    kw = dict(tf=TF, value_range=(0.0, 255.0), shading="phong")
    for cam in cams:
        render(prep, camera=cam, **kw)  # builds what the prepared volume keeps
    rng = np.random.default_rng(5)
    boxes = [(slice(8, 24), slice(0, 16), slice(20, 36)), (slice(30, 40), slice(37, 44), slice(0, 9))]
    new = vol.copy()
    for b in boxes:
        new[b] = rng.integers(0, 256, new[b].shape)
        prep.data[b] = new[b]
    prep.rewritten(boxes)
    for cam in cams:
        img = render(prep, camera=cam, **kw)
        assert img[..., 3].max() > 0.05
        np.testing.assert_array_equal(img, render(new, camera=cam, **kw))
    mins, maxs = prep.brick_ranges(None, rc.brick_size(vol.shape), None)
    fresh = [np.empty_like(mins), np.empty_like(maxs)]
    rc.brick_ranges(new, rc.brick_size(vol.shape), *fresh)
    np.testing.assert_array_equal(mins, fresh[0])
    np.testing.assert_array_equal(maxs, fresh[1])
