"""Quantised normals (volpack.render.normals): codes against a central-difference
reference, images against the exact normals, the memory bound, chunks computed on
demand, thread counts, and the cases where a renderer breaks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import slow_case
from naive import render_normal_code, render_unit_gradient
from test_render_fast import field, semi

from volpack.render.camera import Camera
from volpack.render.normals import CHUNK, LEVELS, NormalCodes, chunk_runs, decoded, light_table
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render


def psnr(a, b) -> float:
    mse = float(np.mean((a[..., :3].astype(np.float64) - b[..., :3]) ** 2))
    return 99.0 if mse == 0 else 10 * math.log10(1.0 / mse)


# the largest angle between a direction and the nearest code's (half a quantisation
# step along both axes of the octahedral square, stretched where the octahedron is)
MAX_DEG = 0.6


@pytest.mark.parametrize("dtype", ["uint8", "int16", "float32"])
def test_codes_match_the_central_difference_reference(dtype):
    f = field((7, 9, 8))
    vol = (np.round(f * 200) if dtype != "float32" else f).astype(dtype)
    vol[1:5, 2:6, 1:7] = vol[1, 2, 1]  # a flat patch: vanishing gradients inside
    sp = (2.0, 1.0, 0.7)
    codes = NormalCodes(vol, sp).ensure(None, 4, 0.5)
    normals = decoded()
    zero = 0
    for z, y, x in np.ndindex(vol.shape):
        ref = render_unit_gradient(vol, sp, z, y, x)
        c = int(codes[z, y, x])
        if ref is None:
            assert c == 0
            zero += 1
            continue
        assert 1 <= c <= LEVELS * LEVELS
        cosang = abs(float(np.dot(normals[c], ref)))
        assert math.degrees(math.acos(min(cosang, 1.0))) < MAX_DEG, (z, y, x)
    assert zero > 0


@pytest.mark.parametrize("dtype", ["uint8", "int16", "float32"])
def test_codes_equal_the_scalar_reference_bit_for_bit(dtype):
    # the row kernel's branch-free, vectorised arithmetic gives each voxel the code of
    # the scalar computation: few values (many ties and exact halves), the volume's
    # edges, rows of one and two voxels, runs of chunks along x, non-finite voxels
    r = np.random.default_rng(7)
    for shape, sp in (((5, 6, 37), (1.0, 1.0, 1.0)), ((18, 3, 2), (2.0, 1.0, 0.7)),
                      ((4, 33, 1), (0.5, 3.0, 1.0))):  # fmt: skip
        vol = r.integers(0, 4, shape).astype(dtype)
        if dtype == "int16":
            vol = vol * 9000 - 13000
        if dtype == "float32":
            vol = vol + r.normal(size=shape).astype(np.float32) * 0.25
            vol.reshape(-1)[::11] = np.nan
            vol.reshape(-1)[3::13] = np.inf
        want = np.array([render_normal_code(vol, sp, *p) for p in np.ndindex(shape)])
        for workers in (1, 3):
            codes = NormalCodes(vol, sp).ensure(None, 4, 0.5, workers)
            np.testing.assert_array_equal(codes.reshape(-1), want)


def test_chunk_runs_cover_the_chunks_once():
    need = np.random.default_rng(3).random((3, 4, 9)) < 0.6
    runs = chunk_runs(np.argwhere(need))
    got = np.zeros(need.shape, int)
    for cz, cy, x0, x1 in runs:
        assert x0 < x1
        got[cz, cy, x0:x1] += 1
    np.testing.assert_array_equal(got, need)
    assert len(runs) == sum(  # maximal: one run per stretch of marked chunks along x
        int(a) and not int(b) for row in need.reshape(-1, 9) for a, b in zip(row, [0, *row[:-1]])
    )


def test_light_table():
    view = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    tab = light_table(view, 0.25, 0.75, 0.35, 24.0)
    ndv = np.abs(decoded() @ view)
    assert tab.dtype == np.float32 and tab.shape == (LEVELS * LEVELS + 1, 2)
    assert tuple(tab[0]) == (1.0, 0.0)  # no gradient: unshaded
    np.testing.assert_allclose(tab[1:, 0], 0.25 + 0.75 * ndv[1:], rtol=1e-6)
    np.testing.assert_allclose(tab[1:, 1], 0.35 * ndv[1:] ** 24, rtol=1e-5, atol=1e-12)


@pytest.mark.parametrize("cls", [slow_case("post"), "preintegrated"])  # post: its own march
@pytest.mark.parametrize(
    "dtype", [slow_case("uint8"), slow_case("uint16"), "float32"]
)  # own kernels: float32's are the fast set's others
def test_quantised_images_stay_close_to_exact_normals(cls, dtype):
    f = field((30, 34, 32))
    vol = f.astype(np.float32) if dtype == "float32" else np.round(
        f * (255 if dtype == "uint8" else 60000)).astype(dtype)  # fmt: skip
    lo, hi = float(vol.min()), float(vol.max())
    kw = dict(tf=semi(lo, hi), camera=Camera(azimuth=35, elevation=25, size=(48, 40)),
              classification=cls, shading="phong", spacing=(1.5, 1.0, 0.8))  # fmt: skip
    q = render(vol, **kw)
    e = render(vol, normals="exact", **kw)
    assert e[..., 3].max() > 0.3
    np.testing.assert_array_equal(q[..., 3], e[..., 3])  # opacity does not depend on normals
    # 33.7 dB here (a noisy field, a voxel to 1.5 pixels: shading interpolated between
    # voxels differs most from normals interpolated); 45.5 dB on the MNI152 MRI at 384^2
    assert psnr(q, e) > 32.0


def test_stability_cases():
    f = field()
    kw = dict(tf=semi(), shading="phong", value_range=(0.0, 1.0))
    # one voxel thick, edge-on, from above and at a slant: finite and close to exact
    sheet = f[:1].copy()
    for el in (0, 45, 90):
        cam = Camera(azimuth=10, elevation=el, size=(20, 20))
        a, b = render(sheet, camera=cam, **kw), render(sheet, camera=cam, normals="exact", **kw)
        assert np.all(np.isfinite(a)) and psnr(a, b) > 30.0
    # NaN voxels are empty (their codes come from the filled volume)
    g = f.astype(np.float32)
    g[:, :, :4] = np.nan
    a = render(g, camera=Camera(size=(20, 20)), **kw)
    b = render(g, camera=Camera(size=(20, 20)), normals="exact", **kw)
    assert np.all(np.isfinite(a)) and psnr(a, b) > 30.0
    # perspective frames keep the exact normals
    cam = Camera(azimuth=20, elevation=10, distance=2.0, projection="perspective", size=(20, 20))
    np.testing.assert_array_equal(render(f, camera=cam, **kw),
                                  render(f, camera=cam, normals="exact", **kw))  # fmt: skip
    with pytest.raises(Exception, match="normals"):
        render(f, tf=semi(), normals="nearest")


def test_codes_are_bounded_and_built_for_what_the_tf_shows():
    vol = np.zeros((64, 40, 48), np.uint8)
    vol[:16, :16, :16] = np.round(field((16, 16, 16)) * 255)  # one corner holds anything
    cam = Camera(size=(24, 24))
    kw = dict(tf=semi(0, 255), camera=cam, shading="phong")
    p = prepare_volume(vol)
    one = render(p, **kw)
    nc = p.normal_codes(None, (1.0, 1.0, 1.0))
    assert nc.codes.dtype == np.uint16 and nc.codes.nbytes == vol.size * 2
    # only the chunks around the visible corner (its 16^3 and the next along each axis)
    assert 1 <= nc.done.sum() <= 8 < nc.done.size
    assert not nc.codes[CHUNK * 2 :].any()
    assert np.array_equal(render(p, **kw), one)  # kept across frames


@pytest.mark.slow  # gradients on the fly for uint8: march variants of their own
def test_over_the_budget_no_codes_and_gradients_on_the_fly():
    vol = np.zeros((64, 40, 48), np.uint8)
    vol[:16, :16, :16] = np.round(field((16, 16, 16)) * 255)
    kw = dict(tf=semi(0, 255), camera=Camera(size=(24, 24)), shading="phong")
    # over the budget: no codes, gradients (here on the fly too: 6 bytes a voxel)
    q = prepare_volume(vol, gradient_budget=vol.size * 2 - 1)
    assert q.normal_codes(None, (1.0, 1.0, 1.0)) is None
    np.testing.assert_allclose(render(q, **kw), render(vol, normals="exact", **kw), atol=1e-6)


@pytest.mark.slow  # uint8 normal-code marches of their own; the fast path's test covers threads
def test_images_do_not_depend_on_the_thread_count():
    vol = np.round(field((30, 26, 28)) * 255).astype(np.uint8)
    for cls in ("post", "preintegrated"):
        kw = dict(tf=semi(0, 255), camera=Camera(azimuth=70, size=(30, 26)), shading="phong",
                  classification=cls)  # fmt: skip
        one = render(vol, workers=1, **kw)
        for w in (2, 3):
            assert np.array_equal(one, render(prepare_volume(vol), workers=w, **kw))


@pytest.mark.slow  # compiles the exact-normals kernels for itself (the library test above covers both)
def test_cli_normals_option(tmp_path):
    from click.testing import CliRunner
    from PIL import Image

    from volpack.cli import main
    from volpack.render.autotf import transfer_for
    from volpack.render.image import to_rgb8

    vol = np.round(field((20, 22, 24)) * 255).astype(np.uint8)
    np.save(tmp_path / "v.npy", vol)
    lo, hi = float(vol.min()), float(vol.max())
    tf = transfer_for("generic", vol, lo=lo, hi=hi, dtype=vol.dtype, mask=None, size=24)
    cam = Camera(azimuth=30, elevation=20, size=(32, 28))
    run = CliRunner().invoke
    got = {}
    for normals in ("quantised", "exact"):
        out = tmp_path / f"{normals}.png"
        r = run(main, ["render", str(tmp_path / "v.npy"), str(out), "--size", "32x28", "--tf",
                       "generic", "--no-fit", "--normals", normals, "--json"])  # fmt: skip
        assert r.exit_code == 0, r.output
        assert '"normals": "%s"' % normals in r.stdout
        got[normals] = np.asarray(Image.open(out))[..., :3]
        want = render(prepare_volume(vol), tf=tf, camera=cam, value_range=(lo, hi),
                      shading="phong", normals=normals)  # fmt: skip
        np.testing.assert_array_equal(got[normals], to_rgb8(want)[..., :3])
    assert not np.array_equal(got["quantised"], got["exact"])  # the option reaches the renderer
    for cmd in ("render", "play", "walk"):
        r = run(main, [cmd, "--help"])
        assert "--normals [quantised|exact]" in r.output
    r = run(main, ["render", str(tmp_path / "v.npy"), str(tmp_path / "x.png"), "--normals", "x"])
    assert r.exit_code == 2 and "quantised" in r.output
