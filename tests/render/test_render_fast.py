"""The ray caster's fast path (_march in volpack.render.raycast) and the per-volume preparation
(volpack.render.prepared) against the general kernel and on-the-fly gradients, on the
cases where a renderer breaks: one voxel thick, anisotropic voxels, the camera inside,
fully transparent and fully opaque transfer functions, NaN voxels, 16-bit and float
volumes, and a gradient volume over its memory budget."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import slow_case

import volpack.render.raycast as rc
from volpack.errors import VolpackError
from volpack.render.camera import Camera
from volpack.render.prepared import gradient_volume, prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction


def field(shape=(20, 24, 22), seed=0) -> np.ndarray:
    """Smooth blobs in [0, 1] plus a little noise."""
    r = np.random.default_rng(seed)
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    f = 0.5 + 0.3 * np.sin(3 * z + 2 * y) * np.cos(2.5 * x - y) + 0.02 * r.normal(size=shape)
    return np.clip(f, 0, 1)


def semi(lo=0.0, hi=1.0) -> TransferFunction:
    r = hi - lo
    return TransferFunction(points=((lo + 0.3 * r, 0, 0, 0, 0.0), (lo + 0.6 * r, 0.9, 0.6, 0.5, 0.2),
                                    (hi, 1.0, 1.0, 1.0, 0.5)))  # fmt: skip


def both(vol, **kw):
    """(fast path with exact normals, general kernel with on-the-fly gradients)."""
    fast = render(vol, normals="exact", **kw)
    rc.FAST_PATH = False
    try:
        slow = render(prepare_volume(vol, kw.pop("spacing", None), gradient_budget=0), **kw)
    finally:
        rc.FAST_PATH = True
    return fast, slow


# post-classified Phong compiles a float32 march of its own: slow set
CASES = [("post", "none"), pytest.param("post", "phong", marks=pytest.mark.slow),
         ("preintegrated", "none"), ("preintegrated", "phong")]  # fmt: skip


@pytest.mark.parametrize("cls, shading", CASES)
# every dtype compiles kernel variants of its own: the fast set keeps float32 (the march
# kernels' uint8 variants come from the walk and octree tests), the slow set the rest
@pytest.mark.parametrize(
    "dtype",
    [slow_case("uint8"), slow_case("uint16"), slow_case("int16"), "float32", slow_case("float64")],
)
def test_fast_path_equals_the_general_kernel(cls, shading, dtype):
    f = field()
    if dtype == "uint8":
        vol = np.round(f * 255).astype(np.uint8)
    elif dtype == "uint16":  # differences too large for int16 gradients: float32 ones
        vol = np.round(f * 60000).astype(np.uint16)
    elif dtype == "int16":
        vol = np.round(f * 4000 - 1024).astype(np.int16)
    else:
        vol = f.astype(dtype)
    lo, hi = float(vol.min()), float(vol.max())
    kw = dict(tf=semi(lo, hi), camera=Camera(azimuth=35, elevation=25, size=(28, 24)),
              classification=cls, shading=shading, step=0.6)  # fmt: skip
    fast, slow = both(vol, **kw)
    assert slow[..., 3].max() > 0.3
    np.testing.assert_allclose(fast, slow, atol=1e-5)


@pytest.mark.parametrize("cls", [slow_case("post"), "preintegrated"])  # post: a Phong march
def test_stability_cases_agree_with_the_general_kernel(cls):
    f = field()
    tf = semi()
    kw = dict(tf=tf, classification=cls, shading="phong", value_range=(0.0, 1.0))
    # one voxel thick, seen edge-on, from above and at a slant
    sheet = f[:1].copy()
    for el in (0, 45, 90):
        a, b = both(sheet, camera=Camera(azimuth=10, elevation=el, size=(20, 20)), **kw)
        assert np.all(np.isfinite(a))
        np.testing.assert_allclose(a, b, atol=1e-5)
    # anisotropic spacing
    a, b = both(f, spacing=(2.5, 1.0, 0.7), camera=Camera(azimuth=50, size=(24, 24)), **kw)
    assert a[..., 3].max() > 0.3
    np.testing.assert_allclose(a, b, atol=1e-5)
    # camera inside, perspective and orthographic
    for proj in ("perspective", "orthographic"):
        cam = Camera(azimuth=20, elevation=10, distance=2.0, projection=proj, size=(20, 20))
        a, b = both(f, camera=cam, **kw)
        assert a[..., 3].max() > 0
        np.testing.assert_allclose(a, b, atol=1e-5)
    # NaN voxels are empty, in both
    g = f.astype(np.float32)
    g[:, :, :4] = np.nan
    a, b = both(g, camera=Camera(size=(20, 20)), **kw)
    assert np.all(np.isfinite(a))
    np.testing.assert_allclose(a, b, atol=1e-5)


# the uint8 unshaded marches (post and pre-integrated) are compiled for this test and the
# resident walk's alone (10 CPU s each): both run in the slow set
@pytest.mark.slow
@pytest.mark.parametrize("cls", ["post", "preintegrated"])
def test_fully_transparent_and_fully_opaque_on_the_fast_path(cls):
    vol = np.round(field() * 255).astype(np.uint8)
    cam = Camera(size=(20, 20))
    clear = TransferFunction(points=((0, 1, 1, 1, 0.0), (255, 1, 1, 1, 0.0)))
    assert not render(vol, tf=clear, camera=cam, classification=cls, shading="phong").any()
    solid = TransferFunction(points=((0, 0.2, 0.4, 0.6, 1.0), (255, 0.2, 0.4, 0.6, 1.0)))
    img = render(vol, tf=solid, camera=cam, classification=cls, shading="none")
    hit = img[..., 3] > 0
    assert hit.sum() > 100
    np.testing.assert_allclose(img[hit][:, 3], 1.0, atol=1e-6)
    np.testing.assert_allclose(img[hit][:, :3], np.tile([0.2, 0.4, 0.6], (hit.sum(), 1)),
                               atol=1e-5)  # fmt: skip


def test_gradient_volume_is_the_central_difference_and_fits_its_dtype():
    vol = np.round(field() * 255).astype(np.uint8)
    g = gradient_volume(vol, np.int16, workers=2)
    v = vol.astype(np.int64)
    ref = np.empty(g.shape, np.int64)
    for ax in range(3):
        up = np.take(v, np.minimum(np.arange(v.shape[ax]) + 1, v.shape[ax] - 1), axis=ax)
        dn = np.take(v, np.maximum(np.arange(v.shape[ax]) - 1, 0), axis=ax)
        ref[..., ax] = up - dn
    assert g.dtype == np.int16 and np.array_equal(g, ref)
    # uint16 over the whole range: float32, exact
    big = np.zeros((3, 3, 3), np.uint16)
    big[2] = 65535
    p = prepare_volume(big)
    gg = p.gradients(None)
    assert gg.dtype == np.float32 and gg[1, 1, 1, 0] == 65535.0


@pytest.mark.slow  # the uint8 Phong march with exact normals: a kernel of its own in the fast set
def test_prepared_volume_is_reused_and_bounded():
    vol = np.round(field() * 255).astype(np.uint8)
    kw = dict(tf=semi(0, 255), camera=Camera(size=(16, 16)), shading="phong", normals="exact")
    p = prepare_volume(vol)
    one = render(p, **kw)
    g = p.gradients(None)
    assert g is not None and g.nbytes == vol.size * 6
    assert render(p, **kw) is not one and p.gradients(None) is g  # built once
    # over the budget: no gradient volume, gradients on the fly, the same image
    q = prepare_volume(vol, gradient_budget=vol.size * 6 - 1)
    assert np.allclose(render(q, **kw), one, atol=1e-5) and q.gradients(None) is None
    with pytest.raises(VolpackError, match="gradient budget"):
        prepare_volume(vol, gradient_budget=-1)


@pytest.mark.slow  # a uint8 Phong march of its own (9.5 CPU s to compile) that no other fast test needs
def test_images_do_not_depend_on_the_thread_count_on_the_fast_path():
    vol = np.round(field((30, 26, 28)) * 255).astype(np.uint8)
    kw = dict(tf=semi(0, 255), camera=Camera(azimuth=70, size=(30, 26), projection="perspective"),
              shading="phong")  # fmt: skip
    one = render(vol, workers=1, **kw)
    for w in (2, 3):
        assert np.array_equal(one, render(vol, workers=w, **kw))


def test_tiles_cover_every_pixel_once_in_bands_of_neighbours():
    # the fast march's loop (_march_specialised): bands by band_end, then tiles
    rows = np.concatenate([np.arange(0, 40), np.arange(60, 70)])  # two runs of rows
    tiles = np.append(np.arange(0, 75, rc.TILE_COLS), 75)
    hit = np.zeros((70, 75), int)
    k0 = 0
    while k0 < len(rows):
        k1 = rc.band_end(rows, k0, rc.ROW_BAND)
        r = rows[k0:k1]
        assert np.all(np.diff(r) == 1) and 1 <= len(r) <= rc.ROW_BAND
        assert k1 == len(rows) or len(r) == rc.ROW_BAND or rows[k1] != rows[k1 - 1] + 1
        for c0, c1 in zip(tiles[:-1], tiles[1:]):
            assert c1 - c0 <= rc.TILE_COLS
            hit[r, c0:c1] += 1
        k0 = k1
    assert np.array_equal(hit[rows], np.ones((len(rows), 75), int)) and hit.sum() == 50 * 75


@pytest.mark.slow  # the general kernel's uint8 variant, compiled for this test alone
def test_a_partial_last_tile_equals_the_general_kernel():
    vol = np.round(field() * 255).astype(np.uint8)
    kw = dict(tf=semi(0, 255), camera=Camera(azimuth=20, size=(rc.TILE_COLS + 5, 6)), step=0.7)
    fast, slow = both(vol, **kw)
    assert slow[..., 3].max() > 0.3
    np.testing.assert_allclose(fast, slow, atol=1e-5)


def faint(lo=0.0, hi=1.0) -> TransferFunction:
    """A semi-transparent TF faint enough for nearest-entry look-ups (rc.NEAREST_STEP)."""
    r = hi - lo
    return TransferFunction(points=((lo + 0.3 * r, 0, 0, 0, 0.0), (lo + 0.6 * r, 0.9, 0.6, 0.5, 0.02),
                                    (hi, 1.0, 1.0, 1.0, 0.05)))  # fmt: skip


def test_smooth_tables_are_read_at_the_nearest_entry_in_both_kernels():
    f = field().astype(np.float32)
    kw = dict(camera=Camera(azimuth=35, elevation=25, size=(28, 24)), step=0.6,
              value_range=(0.0, 1.0))  # fmt: skip
    tabs = {}
    for name, tf in (("faint", faint()), ("semi", semi())):
        base = rc.transfer_table(tf, 0.0, 1.0, rc.TABLE_SIZE)
        tabs[name] = rc._frame_tables(base, 0.6, True, False, "fast").nearest()
    assert tabs == {"faint": True, "semi": False}
    fast, slow = both(f, tf=faint(), **kw)
    assert fast[..., 3].max() > 0.05
    np.testing.assert_allclose(fast, slow, atol=1e-5)
    rc.NEAREST = False
    try:
        lin = render(f, tf=faint(), **kw)
        semi_lin = render(f, tf=semi(), **kw)
    finally:
        rc.NEAREST = True
    # nearest and bilinear differ per segment by at most 2 NEAREST_STEP of a premultiplied
    # channel; over a ray that is at most its segments' count times that (bound), far
    # less in fact (the errors change sign)
    err = np.abs(fast - lin)
    assert 0 < err.max() <= 2 * rc.NEAREST_STEP * 3 * max(f.shape) / 0.6
    assert err.mean() < 1e-4
    assert np.array_equal(semi_lin, render(f, tf=semi(), **kw))  # bilinear there anyway


# slow set: the only fast user of its kernel signatures (session 34, scripts/pytest_kerneluse.py)
@pytest.mark.slow
@pytest.mark.parametrize("case", ["plain", "no skipping", "terminated", "refined"])
def test_the_near_run_gives_the_plain_loops_image_bit_for_bit(case):
    # _near_run marches most segments of an unshaded nearest-entry frame; with it off, the
    # march's own loop takes them: the same pixels and segment counts, through empty-space
    # leaps, early termination (a low threshold) and refinement (a low trigger)
    vol = np.round(field((26, 30, 28)) * 255).astype(np.uint8)
    vol[8:14, 10:20, 6:12] = 0  # clear bricks inside, for leaps
    lo, hi = float(vol.min()), float(vol.max())
    kw = dict(spacing=(1.0, 0.9, 1.1), tf=faint(lo, hi), step=0.5, render_stats=True,
              camera=Camera(azimuth=35, elevation=25, size=(40, 36)),
              skip_empty=case != "no skipping", ert=0.1 if case == "terminated" else 0.99)  # fmt: skip
    trigger = rc.REFINE_OPACITY
    rc.REFINE_OPACITY = 0.005 if case == "refined" else trigger
    try:
        fast, st = render(vol, **kw)
        rc.NEAR_RUN = False
        try:
            plain, st_plain = render(vol, **kw)
        finally:
            rc.NEAR_RUN = True
    finally:
        rc.REFINE_OPACITY = trigger
    assert fast[..., 3].max() > (0.09 if case == "terminated" else 0.05)
    assert np.array_equal(fast, plain)
    assert st.samples == st_plain.samples > 0


@pytest.mark.slow
@pytest.mark.parametrize("dtype", ["int16", "uint8"])
def test_nearest_entries_agree_between_the_kernels_on_integer_volumes(dtype):
    # the fast path samples integers in fixed point, the general kernel in float: both
    # must still pick the same entries
    f = field()
    vol = (np.round(f * 4000 - 1024).astype(np.int16) if dtype == "int16"
           else np.round(f * 255).astype(np.uint8))  # fmt: skip
    lo, hi = float(vol.min()), float(vol.max())
    base = rc.transfer_table(faint(lo, hi), lo, hi, rc.TABLE_SIZE)
    assert rc._frame_tables(base, 0.6, True, False, "fast").nearest()
    kw = dict(tf=faint(lo, hi), camera=Camera(azimuth=35, elevation=25, size=(28, 24)), step=0.6)
    fast, slow = both(vol, **kw)
    assert fast[..., 3].max() > 0.05
    np.testing.assert_allclose(fast, slow, atol=1e-5)
