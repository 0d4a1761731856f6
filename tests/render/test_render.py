"""The reference ray caster: camera, compositing against closed forms, the pre-integration
claim, accelerations that must not change the image, edge cases, PNG output and the CLI."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import slow_case

from volpack.cli import main
from volpack.errors import VolpackError
from volpack.render.camera import Camera
from volpack.render.image import save_png, to_rgb8
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

GOLDEN = Path(__file__).resolve().parent / "golden_render"


def flat_tf(a: float, rgb=(1.0, 0.5, 0.25)) -> TransferFunction:
    return TransferFunction(points=((0.0, *rgb, a), (1.0, *rgb, a)), name="flat")


def ball(n: int = 40, radius: float = 10.0) -> np.ndarray:
    """Distance from the volume centre (a sphere is one of its level sets)."""
    c = (n - 1) / 2
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float32) - c,) * 3, indexing="ij")
    return np.sqrt(z * z + y * y + x * x)


def blob_tf() -> TransferFunction:
    """Distance field: opaque-ish inside radius 8, clear outside 10."""
    return TransferFunction(
        points=((0.0, 1.0, 0.8, 0.6, 0.3), (8.0, 0.9, 0.4, 0.2, 0.3), (10.0, 0.5, 0.2, 0.1, 0.0)),
        name="blob",
    )


# --------------------------------------------------------------------------- camera


@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
@pytest.mark.parametrize("az, el", [(0, 0), (37, 25), (200, -60), (90, 90)])
def test_centre_ray_hits_the_volume_centre(projection, az, el):
    shape, spacing = (20, 30, 40), (2.0, 1.0, 0.5)
    cam = Camera(azimuth=az, elevation=el, projection=projection, size=(33, 21))
    o, d = cam.rays(shape, spacing)
    assert o.shape == d.shape == (21, 33, 3)
    centre = (np.array(shape) - 1) / 2
    # distance from the centre to the middle pixel's ray, in world units
    sp = np.array(spacing)
    ow, dw = o[10, 16] * sp, d[10, 16] * sp
    dw = dw / np.linalg.norm(dw)
    v = centre * sp - ow
    assert np.linalg.norm(v - (v @ dw) * dw) < 1e-9
    assert v @ dw > 0  # in front of the camera
    # t counts reference lengths (the smallest spacing, 0.5): |d| in world = 0.5
    np.testing.assert_allclose(np.linalg.norm(d * sp, axis=-1), 0.5)


def test_whole_volume_in_view_and_axes():
    vol = np.ones((10, 14, 18), np.float32)
    for az, el, persp in [(0, 0, False), (45, 35, False), (120, -50, True)]:
        cam = Camera(
            azimuth=az,
            elevation=el,
            size=(40, 30),
            projection=("perspective" if persp else "orthographic"),
        )
        img = render(vol, tf=flat_tf(0.9), camera=cam, shading="none", classification="post")
        a = img[..., 3]
        assert a[0].max() == a[-1].max() == a[:, 0].max() == a[:, -1].max() == 0
        assert a.max() > 0.99
    # az = 0, el = 0 looks along +y: image columns are x, rows run from high z down
    vol = np.zeros((16, 16, 16), np.float32)
    vol[12:, :, 12:] = 1.0  # high z, high x: the top right corner of the image
    tf = TransferFunction(points=((0.0, 1, 1, 1, 0.0), (0.5, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 1.0)))
    img = render(vol, tf=tf, camera=Camera(0, 0, size=(32, 32)), classification="post")
    a = img[..., 3]
    assert a[:16, 16:].sum() > 0 and a[16:].sum() == 0 and a[:, :16].sum() == 0


# --------------------------------------------------------------------------- compositing


# POST_PHONG: the float32 post-classified shaded march (14 CPU s to compile) is reached by
# these stability cases alone, so their post-classified case runs in the slow set
POST_PHONG = [slow_case("post"), "pre", "preintegrated"]


@pytest.mark.parametrize("mode", POST_PHONG)
def test_empty_volume_is_black(mode):
    vol = np.zeros((12, 12, 12), np.float32)
    tf = TransferFunction(points=((0.0, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.5)))
    img = render(vol, tf=tf, camera=Camera(size=(16, 16)), classification=mode,
                 shading="phong", value_range=(0, 1))  # fmt: skip
    assert img.dtype == np.float32 and img.shape == (16, 16, 4)
    assert not img.any()


@pytest.mark.parametrize("mode", ["post", "preintegrated", "pre"])
@pytest.mark.parametrize("step", [0.5, 0.3, 2.0])
def test_constant_volume_matches_the_closed_form(mode, step):
    a = 0.05
    vol = np.full((16, 16, 16), 3.0, np.float32)
    # anisotropic: along y (the view axis) the voxels are 2 long, the reference length is 1
    spacing = (1.0, 2.0, 1.0)
    cam = Camera(azimuth=0, elevation=0, size=(17, 17))
    img = render(vol, spacing=spacing, tf=flat_tf(a), camera=cam, step=step,
                 classification=mode, shading="none")  # fmt: skip
    expect = 1 - (1 - a) ** (16 * 2.0)
    assert img[8, 8, 3] == pytest.approx(expect, abs=2e-4)
    np.testing.assert_allclose(img[8, 8, :3], np.array([1.0, 0.5, 0.25]) * expect, atol=5e-4)


def comb_tf(n_teeth: int = 12) -> TransferFunction:
    """A high-frequency TF: narrow opaque teeth of alternating colour over [0, 1]."""
    pts = [(0.0, 0, 0, 0, 0.0)]
    for k in range(n_teeth):
        c = (k + 0.5) / n_teeth
        rgb = (1.0, 0.2, 0.1) if k % 2 else (0.1, 0.5, 1.0)
        pts += [(c - 0.012, *rgb, 0.0), (c, *rgb, 0.6), (c + 0.012, *rgb, 0.0)]
    pts.append((1.0, 0, 0, 0, 0.0))
    return TransferFunction(points=tuple(pts), name="comb")


def test_preintegration_beats_post_classification_at_a_large_step():
    n = 32
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 3, indexing="ij")
    vol = (0.5 + 0.45 * np.sin(5.0 * y + 2.0 * x) * np.cos(3.0 * z)).astype(np.float32)
    tf, cam = comb_tf(), Camera(azimuth=10, elevation=5, size=(24, 24))
    kw = dict(tf=tf, camera=cam, shading="none", value_range=(0.0, 1.0))
    ref = render(vol, classification="post", step=0.02, **kw)
    pre = render(vol, classification="preintegrated", step=2.0, **kw)
    post = render(vol, classification="post", step=2.0, **kw)
    err_pre = np.abs(pre - ref).mean()
    err_post = np.abs(post - ref).mean()
    assert ref[..., 3].max() > 0.5
    assert err_pre < 0.5 * err_post, (err_pre, err_post)


@pytest.mark.parametrize("shading", ["preintegrated", "centroid"])
def test_preintegrated_lighting_equals_phong_for_a_constant_normal(shading):
    # v = z: the normal is the same everywhere inside; opacity only well inside in z
    n = 24
    vol = np.broadcast_to(np.arange(n, dtype=np.float32)[:, None, None], (n, n, n)).copy()
    tf = TransferFunction(
        points=((0, 1, 1, 1, 0.0), (6, 1, 1, 1, 0.0), (8, 0.2, 0.9, 0.5, 0.4),
                (16, 0.9, 0.2, 0.3, 0.2), (18, 1, 1, 1, 0.0), (23, 1, 1, 1, 0.0))
    )  # fmt: skip
    kw = dict(tf=tf, camera=Camera(azimuth=20, elevation=35, size=(32, 32)), step=0.7,
              classification="preintegrated", preint_method="exact", value_range=(0, n - 1))  # fmt: skip
    phong = render(vol, shading="phong", **kw)
    lit = render(vol, shading=shading, **kw)
    assert phong[..., 3].max() > 0.5
    np.testing.assert_allclose(lit, phong, atol=2e-5)


def test_preintegrated_lighting_needs_preintegrated_classification():
    with pytest.raises(VolpackError, match="classification='preintegrated'"):
        render(ball(8), tf=blob_tf(), shading="preintegrated", classification="post")


# --------------------------------------------------------------------------- accelerations


@pytest.mark.parametrize("mode", [slow_case("post"), "preintegrated"])
def test_early_ray_termination_stays_within_its_threshold(mode):
    vol = ball()
    tf = TransferFunction(
        points=((0.0, 1, 0.8, 0.6, 0.7), (8.0, 0.9, 0.4, 0.2, 0.7), (10.0, 0.5, 0.2, 0.1, 0.0))
    )
    kw = dict(tf=tf, camera=Camera(size=(32, 32), zoom=2.5), shading="phong")
    full, s_full = render(vol, ert=1.0, classification=mode, render_stats=True, **kw)
    ert, s_ert = render(vol, ert=0.99, classification=mode, render_stats=True, **kw)
    assert s_ert.samples < 0.8 * s_full.samples, (s_ert, s_full)
    assert np.abs(full - ert).max() <= 0.011
    assert np.abs(full[..., 3] - ert[..., 3]).max() <= 0.01


def test_a_terminated_ray_ends_in_the_colour_of_its_last_segment():
    # one colour everywhere: what termination leaves out is that colour, so the
    # completed image is the one without termination, up to the light behind the ball
    vol = ball(40, 14)
    tf = TransferFunction(points=((0.0, 0.9, 0.6, 0.3, 0.6), (14.0, 0.9, 0.6, 0.3, 0.6),
                                  (16.0, 0.9, 0.6, 0.3, 0.0)))  # fmt: skip
    kw = dict(tf=tf, camera=Camera(size=(24, 24)))
    for mode in ("post", "preintegrated"):
        full = render(vol, ert=1.0, classification=mode, **kw)
        ert = render(vol, ert=0.99, classification=mode, **kw)
        centre = full[..., 3] > 0.9999
        assert centre.sum() > 50 and np.all(ert[centre, 3] == 1.0)
        assert np.abs(full - ert)[centre].max() < 2e-4


def wavy_opaque(size: int, shading: str) -> tuple:
    """A smooth float field, an opaque TF with a steep ramp over a tenth of its range and
    the render options of a step-0.5 view of it."""
    n = 32
    z, y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 3, indexing="ij")
    vol = (0.5 + 0.45 * np.sin(5.0 * y + 2.0 * x) * np.cos(3.0 * z)).astype(np.float32)
    opaque = TransferFunction(points=((0.55, 0, 0, 0, 0), (0.65, 0.9, 0.7, 0.5, 0.9),
                                      (1.0, 1, 1, 1, 1)))  # fmt: skip
    kw = dict(camera=Camera(azimuth=10, elevation=5, size=(size, size)),
              value_range=(0.0, 1.0), shading=shading, step=0.5)  # fmt: skip
    return vol, opaque, kw


def test_refinement_brings_opaque_surfaces_nearer_a_fine_step():
    # a sharp opacity ramp crossed in one segment: the chord between the segment's
    # samples misplaces the surface; two sub-segments halve that, semi-transparent
    # segments are left alone
    vol, opaque, kw = wavy_opaque(24, "phong")
    ref = render(vol, tf=opaque, refine=1, **{**kw, "step": 0.05})
    plain, st1 = render(vol, tf=opaque, refine=1, render_stats=True, **kw)
    refined, st = render(vol, tf=opaque, refine=2, render_stats=True, **kw)
    err_plain = np.abs(plain - ref).mean()
    err_refined = np.abs(refined - ref).mean()
    assert ref[..., 3].max() > 0.9
    assert err_refined < 0.6 * err_plain, (err_refined, err_plain)
    assert st1.samples < st.samples < 1.3 * st1.samples
    faint = TransferFunction(points=((0.55, 0, 0, 0, 0), (1.0, 1, 1, 1, 0.15)))
    np.testing.assert_array_equal(render(vol, tf=faint, refine=2, **kw),
                                  render(vol, tf=faint, refine=1, **kw))  # fmt: skip
    with pytest.raises(VolpackError, match="refine"):
        render(vol, tf=faint, refine=0, **kw)


@pytest.mark.parametrize("shading", ["none", "phong"])
def test_the_lean_refinement_call_gives_the_shaded_calls_image_bit_for_bit(shading):
    # unshaded frames refine through _refined_plain (a third of the call's arguments),
    # frames lit through quantised normals through _refined_lit (session 37): the same
    # sums as _refined, with two and three sub-segments, to early termination
    from volpack.render import raycast

    vol, opaque, kw = wavy_opaque(24, shading)
    for refine in (2, 3):
        lean, st = render(vol, tf=opaque, refine=refine, render_stats=True, **kw)
        raycast.LEAN_REFINE = False
        try:
            full, st_full = render(vol, tf=opaque, refine=refine, render_stats=True, **kw)
        finally:
            raycast.LEAN_REFINE = True
        plain = render(vol, tf=opaque, refine=1, **kw)
        assert np.abs(lean - plain).max() > 1e-3  # refinement moved pixels
        if shading == "none":
            assert np.array_equal(lean, full)
        else:  # the same sums; the compiler's fused multiply-adds may differ by an ulp
            assert np.abs(lean - full).max() <= 2.5e-7
        assert st.samples == st_full.samples


def test_the_unshaded_refinement_is_inlined_into_the_march():
    # entering _refined_plain as a call cost most of a refined segment (session 39: the
    # opaque unshaded frames 0.92-0.98x inlined, the same images, checked above)
    from volpack.render import raycast

    assert raycast._refined_plain.targetoptions["inline"] == "always"


@pytest.mark.parametrize("mode", POST_PHONG)
def test_empty_space_skipping_leaves_the_image_unchanged(mode):
    vol = ball(48, 10)
    isos = [(6.0, (1.0, 1.0, 0.0), 0.5)] if mode == "preintegrated" else None
    kw = dict(tf=blob_tf(), camera=Camera(azimuth=25, elevation=30, size=(40, 40)),
              classification=mode, shading="phong", isos=isos)  # fmt: skip
    a, sa = render(vol, skip_empty=False, render_stats=True, **kw)
    b, sb = render(vol, skip_empty=True, render_stats=True, **kw)
    np.testing.assert_allclose(a, b, atol=1e-6)
    assert sb.samples < 0.6 * sa.samples


def test_the_image_does_not_depend_on_the_thread_count():
    vol = ball(36, 12)
    kw = dict(tf=blob_tf(), camera=Camera(azimuth=70, size=(30, 26), projection="perspective"),
              shading="phong")  # fmt: skip
    one = render(vol, workers=1, **kw)
    for w in (2, 3, 5):
        assert np.array_equal(one, render(vol, workers=w, **kw))
    assert np.array_equal(one, render(vol, workers=3, **kw, progress=lambda d, t: None))


def test_read_only_and_writable_volumes_share_compiled_kernels():
    # a file read by the CLI arrives read-only, an API array writable: numba would
    # compile every kernel once for each (8 s a march kernel); both must give one image
    # from one set of compiled signatures
    from volpack.render import raycast

    vol = ball(20, 6)
    kw = dict(tf=blob_tf(), camera=Camera(azimuth=30, size=(12, 10)), shading="phong")

    def compiled():
        kernels = {**vars(raycast), **{str(k): f for k, f in raycast._MARCH.items()}}
        return {n: len(f.signatures) for n, f in kernels.items() if hasattr(f, "signatures")}

    img = render(vol, **kw)
    before = compiled()
    ro = vol.copy()
    ro.flags.writeable = False
    assert np.array_equal(render(ro, **kw), img)
    after = compiled()
    assert {n for n in after if after[n] != before.get(n)} == set()


# --------------------------------------------------------------------------- edge cases


def test_nan_voxels_are_empty():
    vol = ball(32, 9)
    clean = render(vol, tf=blob_tf(), camera=Camera(size=(24, 24)), shading="phong")
    dirty = vol.copy()
    dirty[:, :, :3] = np.nan  # far outside the ball: transparent there anyway
    dirty[0, 0, 5] = np.inf
    mn = float(np.nanmin(vol))  # (NaN replaced by the minimum, 0, is opaque: moved)
    img = render(dirty, tf=blob_tf(), camera=Camera(size=(24, 24)), shading="phong",
                 value_range=(mn, float(vol.max())))  # fmt: skip
    assert np.all(np.isfinite(img))
    np.testing.assert_allclose(img, clean, atol=1e-6)
    all_nan = np.full((8, 8, 8), np.nan, np.float32)
    assert not render(all_nan, tf=blob_tf(), camera=Camera(size=(8, 8))).any()


@pytest.mark.parametrize("mode", POST_PHONG)
def test_one_voxel_thick_volume(mode):
    sheet = np.zeros((1, 32, 32), np.float32)
    sheet[0, 8:24, 8:24] = 1.0
    tf = TransferFunction(points=((0.0, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.5)))
    for el in (90, 45, 0):
        img = render(sheet, tf=tf, camera=Camera(0, el, size=(20, 20)),
                     classification=mode, shading="phong")  # fmt: skip
        assert np.all(np.isfinite(img)) and img.min() >= 0
        if el == 90:  # straight down through one voxel
            assert img[10, 10, 3] == pytest.approx(0.5, abs=1e-3)


def test_a_camera_looking_away_sees_nothing():
    away = Camera(look_at=(0, 0, 5000), zoom=40, projection="perspective", size=(16, 16))
    assert not render(ball(16, 4), tf=blob_tf(), camera=away).any()


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("mode", ["post", "preintegrated"])
def test_camera_inside_the_volume_sees_the_distance_to_the_box(mode):
    # constant volume, eye at the centre looking along +y: the centre ray crosses half
    # the box (from y = 15.5 to the face at 31.5), so alpha = 1 - (1 - a) ** 16
    n, a = 32, 0.05
    vol = np.full((n, n, n), 3.0, np.float32)
    cam = Camera(azimuth=0, elevation=0, projection="perspective", distance=0.0, size=(9, 9))
    img = render(vol, tf=flat_tf(a), camera=cam, classification=mode, step=0.5, ert=1.0)
    assert np.all(np.isfinite(img)) and img[..., 3].min() > 0
    assert img[4, 4, 3] == pytest.approx(1 - (1 - a) ** 16.0, rel=2e-3)
    # orthographic: the distance is a near clipping plane through the centre
    cam = Camera(azimuth=0, elevation=0, distance=0.0, size=(9, 9), zoom=2)
    img = render(vol, tf=flat_tf(a), camera=cam, classification=mode, step=0.5, ert=1.0)
    assert img[4, 4, 3] == pytest.approx(1 - (1 - a) ** 16.0, rel=2e-3)
    with pytest.raises(VolpackError, match="distance"):
        Camera(distance=-1.0)


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("mode", POST_PHONG)
def test_fully_transparent_and_fully_opaque_tfs(mode):
    vol = ball(24, 8)
    cam = Camera(size=(20, 20))
    clear = render(vol, tf=flat_tf(0.0), camera=cam, classification=mode, shading="phong")
    assert not clear.any()
    solid = render(vol, tf=flat_tf(1.0, (0.2, 0.4, 0.6)), camera=cam, classification=mode)
    hit = solid[..., 3] > 0
    assert hit.sum() > 100 and np.all(np.isfinite(solid))
    np.testing.assert_allclose(solid[hit][:, 3], 1.0, atol=1e-6)
    np.testing.assert_allclose(
        solid[hit][:, :3], np.tile([0.2, 0.4, 0.6], (hit.sum(), 1)), atol=1e-5
    )


@pytest.mark.filterwarnings("error")
def test_a_spike_narrower_than_a_step_is_not_missed_by_preintegration():
    # values run 0..1 along z; only [0.495, 0.505] is opaque: 0.3 voxels thick, while the
    # step is 2 voxels. Post-classification samples straddle it; pre-integration does not.
    n = 32
    vol = np.broadcast_to(np.linspace(0, 1, n, dtype=np.float32)[:, None, None], (n, n, n)).copy()
    tf = TransferFunction(
        points=((0.0, 1, 1, 1, 0.0), (0.495, 1, 1, 1, 0.0), (0.5, 1, 0.5, 0.2, 0.9),
                (0.505, 1, 1, 1, 0.0), (1.0, 1, 1, 1, 0.0))
    )  # fmt: skip
    kw = dict(tf=tf, camera=Camera(azimuth=0, elevation=80, size=(16, 16)), table_size=1024)
    ref = render(vol, classification="post", step=0.01, **kw)
    pre = render(vol, classification="preintegrated", step=2.0, **kw)
    post = render(vol, classification="post", step=2.0, **kw)
    assert ref[..., 3].mean() > 0.05
    assert np.abs(pre - ref).max() < 0.25 * np.abs(post - ref).max()


def test_isosurface_of_a_sphere_is_a_disc_of_its_radius():
    n, r = 48, 12.0
    cam = Camera(azimuth=15, elevation=20, size=(64, 64))
    img = render(ball(n), tf=None, isos=[(r, (1.0, 1.0, 1.0), 1.0)], camera=cam, shading="phong")
    covered = img[..., 3] > 0.5
    half_view = 1.05 * 0.5 * np.sqrt(3) * n  # half the field at zoom 1 (box half diagonal)
    r_px = np.sqrt(covered.sum() / np.pi) * (2 * half_view / 64)
    assert r_px == pytest.approx(r, rel=0.04)
    # shaded: brighter in the middle (facing the headlight) than at the rim
    grey = img[..., 0]
    assert grey[32, 32] > grey[covered].min() + 0.2


# --------------------------------------------------------------------------- images, CLI


@pytest.mark.parametrize("background", [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.2, 0.7, 0.0)])
def test_rgb8_matches_the_pixel_by_pixel_composite(background):
    # NaN, infinities, -0.0, out-of-range values and exact rounding ties, float64 input too
    from naive import render_rgb8

    rng = np.random.default_rng(7)
    for dtype in (np.float32, np.float64):
        a = (rng.standard_normal((9, 11, 4)) * 1.5).astype(dtype)
        m = rng.random(a.shape)
        a[m < 0.06] = np.nan
        a[(m >= 0.06) & (m < 0.1)] = np.inf
        a[(m >= 0.1) & (m < 0.13)] = -np.inf
        a[(m >= 0.13) & (m < 0.16)] = -0.0
        ties = (m >= 0.16) & (m < 0.3)
        a[ties] = (rng.integers(0, 255, ties.sum()) + 0.5) / 255
        before = a.copy()
        got = to_rgb8(a, background)
        assert got.dtype == np.uint8 and got.shape == (9, 11, 3)
        np.testing.assert_array_equal(got, render_rgb8(a, background))
        np.testing.assert_array_equal(a, before)  # the caller's image is left alone


def test_png_output_and_colour_bar(tmp_path):
    rgba = np.zeros((10, 12, 4), np.float32)
    rgba[2:5, 3:7] = (0.5, 0.25, 0.0, 0.5)
    rgb = to_rgb8(rgba, background=(1.0, 1.0, 1.0))
    assert rgb.shape == (10, 12, 3) and tuple(rgb[3, 4]) == (255, 191, 128)
    from PIL import Image

    save_png(tmp_path / "a.png", rgba)
    with Image.open(tmp_path / "a.png") as f:
        assert f.size == (12, 10)
    save_png(tmp_path / "b.png", rgba, colorbar=(blob_tf(), 0.0, 20.0))
    with Image.open(tmp_path / "b.png") as f:
        w, h = f.size
    assert w == 12 and h > 10
    with pytest.raises(FileExistsError):
        save_png(tmp_path / "a.png", rgba)
    assert sorted(os.listdir(tmp_path)) == ["a.png", "b.png"]  # no temporary left


@pytest.mark.slow  # the only fast user of the uint8 isosurface kernel (5 CPU s to compile)
def test_cli_render_png_orbit_iso_and_json(tmp_path):
    import json

    from PIL import Image

    src = tmp_path / "ball.npy"
    # uint8: the int16 kernel variants are compiled by the slow set's dtype cases
    np.save(src, (ball(24, 8) * 10).astype(np.uint8))
    run = CliRunner()
    r = run.invoke(main, ["render", str(src), str(tmp_path / "a.png"), "--size", "40x30"])
    assert r.exit_code == 0, r.output
    with Image.open(tmp_path / "a.png") as f:
        im = np.asarray(f)
    assert im.shape == (30, 40, 3) and im.max() > 0
    out = tmp_path / "orbit"
    r = run.invoke(main, ["render", str(src), str(out), "--orbit", "3", "--size", "16x16",
                          "--iso", "60:bone,90:#ff0000@0.4", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert sorted(os.listdir(out)) == ["frame_000.png", "frame_001.png", "frame_002.png"]
    rep = json.loads(r.stdout)  # stderr may hold the first-compile notice
    assert len(rep["frames"]) == 3 and rep["samples"] > 0 and rep["tf"] is None
    r = run.invoke(main, ["render", str(src), str(tmp_path / "a.png"), "--colorbar",
                          "--classification", "post", "--shading", "none", "--size", "20x20"])  # fmt: skip
    assert r.exit_code == 1 and "exists" in r.output  # refused without --force
    r = run.invoke(main, ["render", str(src), str(tmp_path / "a.png"), "--colorbar", "--force",
                          "--tf", "generic", "--perspective", "--size", "20x20"])  # fmt: skip
    assert r.exit_code == 0, r.output
    with Image.open(tmp_path / "a.png") as f:
        assert f.size[1] > 20
    r = run.invoke(main, ["render", str(src), str(tmp_path / "c.png"), "--iso", "5:nocolour"])
    assert r.exit_code == 2 and "colour" in r.output


def test_cli_renders_a_vpk(tmp_path):
    from volpack import api

    # uint8: the renderer's int16 kernels are the slow set's (test_render_fast's int16 case)
    vol = (ball(20, 6) * 10).astype(np.uint8)
    api.compress(vol, str(tmp_path / "b.vpk"), codec="zstd")  # no codec kernels to compile
    r = CliRunner().invoke(
        main, ["render", str(tmp_path / "b.vpk"), str(tmp_path / "b.png"), "--size", "16x16"]
    )
    assert r.exit_code == 0, r.output
    assert (tmp_path / "b.png").stat().st_size > 0


def golden_image(brain: np.ndarray, normals: str = "exact") -> np.ndarray:
    small = brain[::4, ::4, ::4].astype(np.float32)  # (21, 32, 32)
    tf = TransferFunction(
        points=(
            (0, 0, 0, 0, 0),
            (40, 0.9, 0.5, 0.4, 0),
            (90, 1, 0.85, 0.7, 0.3),
            (255, 1, 1, 1, 0.6),
        ),
        name="golden",
    )
    return render(small, tf=tf, value_range=(0.0, 255.0),
                  camera=Camera(azimuth=30, elevation=20, size=(32, 32)),
                  shading="phong", classification="preintegrated", normals=normals)  # fmt: skip


@pytest.mark.parametrize("shading", ["none", "phong"])
def test_default_refinement_takes_a_third_sub_segment_where_the_scalar_bends(shading, monkeypatch):
    # six slices six voxels apart: along a ray the trilinear field bends at each slice,
    # and a steep opaque ramp makes the chord between samples misplace surfaces. The
    # default (three sub-segments where the samples' second difference shows a bend,
    # two elsewhere) must bring the step-0.5 image nearer a converged one than two
    # everywhere do, with fewer samples than three everywhere
    import volpack.render.raycast as rc

    n = 24
    y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 2, indexing="ij")
    vol = np.stack([0.5 + 0.4 * np.sin(4 * x + 3 * y + k) * np.cos(2 * y - k)
                    for k in range(6)]).astype(np.float32)  # fmt: skip
    _, opaque, kw = wavy_opaque(48, shading)
    kw.update(camera=Camera(azimuth=30, elevation=20, size=(48, 48)), spacing=(6.0, 1.0, 1.0))
    ref = render(vol, tf=opaque, refine=1, **{**kw, "step": 1 / 32})
    two, st2 = render(vol, tf=opaque, refine=2, render_stats=True, **kw)
    default, st = render(vol, tf=opaque, render_stats=True, **kw)
    monkeypatch.setattr(rc, "REFINE_BEND", 0.0)  # three sub-segments wherever refined
    three, st3 = render(vol, tf=opaque, render_stats=True, **kw)
    err2, err, err3 = (np.abs(im - ref).mean() for im in (two, default, three))
    assert err3 < err < 0.9 * err2, (err3, err, err2)  # measured 0.71 / 0.82 / 1
    assert st2.samples < st.samples < st3.samples


@pytest.mark.parametrize("normals, name", [("exact", "brain_32"), ("quantised", "brain_32_qn")])
def test_golden_demo_render(brain, normals, name):
    # brain_32: normals from the trilinear field (the image before quantised normals);
    # brain_32_qn: the default, quantised normals (max 0.17, mean 2.7e-3 off brain_32)
    img = golden_image(brain, normals)
    path = GOLDEN / f"{name}.npy"
    if os.environ.get("VOLPACK_REGEN_GOLDEN"):
        GOLDEN.mkdir(exist_ok=True)
        np.save(path, img)
        save_png(GOLDEN / f"{name}.png", img, force=True)
    gold = np.load(path)
    assert img.shape == gold.shape == (32, 32, 4)
    assert gold[..., 3].max() > 0.3
    assert np.abs(img - gold).max() < 0.02
    assert np.abs(img - gold).mean() < 2e-3


def test_cli_look_at_moves_the_orbit_centre(tmp_path):
    from PIL import Image

    vol = ball(24, 6)
    np.save(tmp_path / "b.npy", vol)
    run = CliRunner().invoke
    out = {}
    for name, extra in [("c", []), ("off", ["--look-at", "11.5,11.5,2"])]:
        r = run(main, ["render", str(tmp_path / "b.npy"), str(tmp_path / f"{name}.png"),
                       "--size", "32x32", "--azimuth", "0", "--elevation", "0", *extra])  # fmt: skip
        assert r.exit_code == 0, r.output
        out[name] = np.asarray(Image.open(tmp_path / f"{name}.png")).sum(axis=(0, 2))
    # looking at a point left of centre (smaller x) moves the ball to the right of the image
    cols = np.arange(32)
    assert (out["off"] * cols).sum() / out["off"].sum() > (out["c"] * cols).sum() / out[
        "c"
    ].sum() + 1
    r = run(main, ["render", str(tmp_path / "b.npy"), str(tmp_path / "x.png"), "--look-at", "1,2"])
    assert r.exit_code == 2 and "Z,Y,X" in r.output


def test_rays_are_world_rays_in_index_space():
    """Camera.rays (one kernel pass) gives the same numbers as world_rays divided by the
    spacing and scaled to reference lengths with numpy."""
    cams = [Camera(azimuth=30, elevation=20, size=(64, 48)),
            Camera(azimuth=77, elevation=-40, size=(33, 71), zoom=1.3, projection="perspective"),
            Camera(azimuth=10, elevation=5, size=(20, 30), projection="perspective", distance=3.0),
            Camera(azimuth=200, elevation=89, size=(40, 24), zoom=2.0, distance=10.0)]  # fmt: skip
    for cam in cams:
        for shape, sp in [((9, 23, 19), (1, 1, 1)), ((10, 25, 25), (2.5, 0.957, 0.957)),
                          ((1, 5, 70), (1e-3, 7, 0.1))]:  # fmt: skip
            c2, spn, centre, radius = cam.world_frame(shape, sp)
            o, d = c2.world_rays(centre, radius)
            o /= spn
            d *= float(spn.min()) / spn
            o2, d2 = cam.rays(shape, sp)
            np.testing.assert_array_equal(o2, o)
            np.testing.assert_array_equal(d2, d)


def test_a_pixel_ray_is_the_ray_the_camera_gives_it():
    """The fast march makes each ray where it traces it (camera.pixel_ray, compiled
    without fused multiply-adds): the numbers of Camera.rays, bit for bit."""
    from volpack.render.camera import pixel_ray

    cams = [Camera(azimuth=30, elevation=20, size=(64, 48)),
            Camera(azimuth=77, elevation=-40, size=(33, 71), zoom=1.3, projection="perspective"),
            Camera(azimuth=200, elevation=89, size=(40, 24), zoom=2.0, distance=10.0)]  # fmt: skip
    for cam in cams:
        for shape, sp in [((9, 23, 19), (1, 1, 1)), ((1, 5, 70), (1e-3, 7, 0.1))]:
            o, d = cam.rays(shape, sp)
            grid = cam.ray_grid(shape, sp)
            h, w = o.shape[:2]
            for r, c in [(0, 0), (h - 1, w - 1), (h // 2, w // 3), (h - 1, 0), (1, w - 2)]:
                assert pixel_ray(*grid, r, c) == (*o[r, c], *d[r, c])


def _box_hits(cam, shape, sp):
    """Which pixels' rays meet the box [-0.5, n - 0.5] ahead of them (numpy, per ray)."""
    o, d = cam.rays(shape, sp)
    n = np.array(shape, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (-0.5 - o) / d, (n - 0.5 - o) / d
    inside = (o >= -0.5) & (o <= n - 0.5)
    lo = np.where(d == 0, np.where(inside, -np.inf, np.inf), np.minimum(a, b))
    hi = np.where(d == 0, np.where(inside, np.inf, -np.inf), np.maximum(a, b))
    return hi.min(-1) > np.maximum(lo.max(-1), 0.0)


def test_box_columns_hold_every_ray_that_meets_the_box():
    # the fast march traces only these columns of each row: a ray left out must miss
    rng = np.random.default_rng(36)
    narrower = 0
    for k in range(120):
        shape = tuple(int(x) for x in rng.integers(1, 60, 3))
        sp = tuple(float(x) for x in rng.uniform(0.2, 5.0, 3))
        el = float(rng.choice([0.0, 90.0, -90.0, rng.uniform(-90, 90)]))
        cam = Camera(azimuth=float(rng.uniform(-180, 180)), elevation=el,
                     zoom=float(rng.choice([1.0, 0.3, 3.0, rng.uniform(0.1, 10)])),
                     size=(int(rng.integers(1, 90)), int(rng.integers(1, 90))),
                     distance=None if k % 3 else float(rng.uniform(0, 40)))  # fmt: skip
        spans = cam.box_columns(shape, sp)
        cols = np.arange(cam.size[0])[None, :]
        traced = (cols >= spans[:, :1]) & (cols < spans[:, 1:])
        assert not np.any(_box_hits(cam, shape, sp) & ~traced), (shape, sp, cam)
        narrower += traced.mean() < 0.5
    assert narrower > 30  # and they leave out most of a frame of a zoomed-out volume
    persp = Camera(size=(20, 10), projection="perspective", zoom=0.2)
    assert np.array_equal(persp.box_columns((4, 5, 6)), [[0, 20]] * 10)


def test_tracing_only_the_box_columns_leaves_the_image_and_segments_unchanged():
    from volpack.render import raycast

    vol = ball(24, 7.0)
    kw = dict(tf=blob_tf(), render_stats=True,
              camera=Camera(azimuth=25, elevation=35, size=(60, 44), zoom=0.7))  # fmt: skip
    img, st = render(vol, **kw)
    raycast.BOX_SPANS = False
    try:
        every, st_every = render(vol, **kw)
    finally:
        raycast.BOX_SPANS = True
    assert img[..., 3].max() > 0.5 and (img[..., 3] == 0).mean() > 0.3
    assert np.array_equal(img, every)
    assert st.samples == st_every.samples > 0


def test_rays_that_overflow_are_refused_before_any_row_is_traced():
    cam = Camera(size=(8, 6), projection="perspective", distance=1e307)
    with pytest.raises(VolpackError, match="overflows float64"):
        cam.rays((4, 5, 6), (1e-3, 1, 1))
    with pytest.raises(VolpackError, match="overflows float64"):
        cam.ray_grid((4, 5, 6), (1e-3, 1, 1))
    with pytest.raises(VolpackError, match="overflows float64"):
        render(np.arange(120, dtype=np.float32).reshape(4, 5, 6), spacing=(1e-3, 1, 1),
               tf=flat_tf(0.5), camera=cam, shading="none", classification="post")


@pytest.mark.parametrize("h, threads", [(512, 2), (26, 2), (7, 3), (1, 2), (100, 1)])
def test_row_sets_cover_every_row_once_in_bands(h, threads):
    import threading

    from volpack.render import raycast

    seen, lock, done = [], threading.Lock(), []

    def run(rows):
        with lock:
            seen.append(rows.copy())

    raycast.run_row_sets(run, h, threads, progress=lambda d, t: done.append((d, t)))
    rows = np.concatenate(seen)
    assert np.array_equal(np.sort(rows), np.arange(h))
    assert done[-1] == (h, h)
    if threads > 1 and h >= 4 * threads * raycast.ROW_BAND:  # whole bands of neighbours
        for r in seen:
            assert np.all(np.diff(r)[: raycast.ROW_BAND - 1] == 1)


def test_preclassification_past_its_memory_budget_is_a_clear_error(tmp_path, monkeypatch):
    """classification='pre' keeps 16 bytes of RGBA a voxel (session 35, rend35: a 512^3
    uint8 volume rendered in 3.2 GB; a 1024^3 one would have asked 16 GiB more): past
    PRECLASSIFIED_BUDGET it is refused in one line naming the modes that need no copy."""
    from volpack.render import raycast

    monkeypatch.setattr(raycast, "PRECLASSIFIED_BUDGET", 16 * 999)
    vol = np.zeros((10, 10, 10), np.uint8)
    tf = TransferFunction(points=((0, 1, 1, 1, 0.5), (255, 1, 1, 1, 0.5)))
    with pytest.raises(VolpackError, match=r"at most 999 voxels for classification 'pre'.*found 1,000"):
        render(vol, tf=tf, classification="pre", camera=Camera(size=(8, 8)))
    np.save(tmp_path / "v.npy", vol)
    r = CliRunner().invoke(main, ["render", str(tmp_path / "v.npy"), str(tmp_path / "v.png"),
                                  "--classification", "pre", "--size", "8x8"])  # fmt: skip
    assert r.exit_code == 1 and "volpack: error: expected at most 999 voxels" in r.output, r.output
    assert "Traceback" not in r.output and not (tmp_path / "v.png").exists()
