"""Previews without flags: framing on what the transfer function shows (coverage of the
image measured on renders), the histogram-driven automatic transfer function, the lit
surface of meshes without fields, and every documented preset name."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from volpack.cli import main
from volpack.render import autotf
from volpack.render.camera import Camera
from volpack.render.framing import coverage, fit_camera
from volpack.render.raycast import render
from volpack.render.tetra import fit_mesh_camera, render_mesh, render_surface
from volpack.render.transfer import PRESETS, TransferFunction, load_tf

ROOT = Path(__file__).resolve().parents[2]
_DATA = os.path.expanduser(os.environ.get("VOLPACK_DATA", "~/.cache/volpack/data"))


def span(img) -> float:
    """How much of the image the object spans along its tighter side."""
    return max(coverage(img, 0.1))


def blob_volume(n=64, centre=(14, 40, 22), r=8.0, dtype=np.float32, noise=0.0, seed=0):
    """A bright ball off-centre in a large dark grid (the framing must find it)."""
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64),) * 3, indexing="ij")
    d = np.sqrt((z - centre[0]) ** 2 + (y - centre[1]) ** 2 + (x - centre[2]) ** 2)
    v = 100.0 / (1.0 + np.exp((d - r) * 1.5))
    v += np.random.default_rng(seed).normal(0, noise, v.shape) if noise else 0
    return v.astype(dtype)


def head_like_ct(n=48):
    """Air (-1000 HU) around a ball of soft tissue (40 HU) with a bone shell (1200 HU)."""
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) - (n - 1) / 2,) * 3, indexing="ij")
    d = np.sqrt(z * z + y * y + x * x)
    v = np.where(d < 0.4 * n, 40.0, -1000.0)
    v = np.where((d > 0.3 * n) & (d < 0.36 * n), 1200.0, v)
    return v.astype(np.int16)


# --------------------------------------------------------------------------- framing


@pytest.mark.parametrize("projection", ["orthographic", "perspective"])
def test_an_object_in_a_corner_fills_about_80_percent(projection):
    vol = blob_volume()
    tf = autotf.auto_transfer(vol)
    lo, hi = float(vol.min()), float(vol.max())
    cam = Camera(size=(96, 80), projection=projection)
    kw = dict(tf=tf, value_range=(lo, hi), shading="phong")
    before = span(render(vol, camera=cam, **kw))
    fitted = fit_camera(cam, vol, tf, lo, hi)
    after = span(render(vol, camera=fitted, **kw))
    assert before < 0.4  # the whole 64^3 grid framed: the ball is small
    assert 0.72 <= after <= 0.86, after
    # the ball is in the middle of the image: as much empty space left as right
    a = render(vol, camera=fitted, **kw)[..., 3] > 0.1
    cols = np.flatnonzero(a.any(axis=0))
    assert abs(cols[0] - (a.shape[1] - 1 - cols[-1])) <= 3


def test_the_user_zoom_multiplies_the_fit_and_a_given_distance_is_kept():
    vol = blob_volume()
    tf = autotf.auto_transfer(vol)
    cam = Camera(size=(64, 64), zoom=0.5)
    fitted = fit_camera(cam, vol, tf, 0.0, 100.0)
    plain = fit_camera(Camera(size=(64, 64)), vol, tf, 0.0, 100.0)
    assert fitted.zoom == pytest.approx(0.5 * plain.zoom)
    inside = Camera(size=(64, 64), distance=3.0, projection="perspective")
    assert fit_camera(inside, vol, tf, 0.0, 100.0) == inside
    empty = np.zeros((8, 8, 8), np.float32)
    assert fit_camera(cam, empty, tf, 0.0, 100.0) == cam  # nothing visible: unchanged


def test_an_orbit_keeps_one_frame_that_holds_every_view():
    vol = blob_volume(centre=(30, 20, 40), r=7)
    vol[26:34, 14:26, 8:48] = 90  # a bar along x: wide from the front, narrow from the side
    tf = autotf.auto_transfer(vol)
    azimuths = [0, 45, 90, 135, 180, 225, 270, 315]
    cam = fit_camera(Camera(size=(64, 64)), vol, tf, 0.0, 100.0, azimuths=azimuths)
    spans = []
    for az in azimuths:
        view = Camera(**{**cam.__dict__, "azimuth": az})
        spans.append(span(render(vol, tf=tf, camera=view, value_range=(0.0, 100.0))))
    assert max(spans) <= 0.9 and max(spans) >= 0.7, spans


def test_noise_voxels_do_not_stretch_the_frame():
    vol = blob_volume(noise=0.0)
    rng = np.random.default_rng(1)
    idx = tuple(rng.integers(0, 64, size=(3, 20)))
    vol[idx] = 100.0  # 20 stray bright voxels all over the grid
    tf = autotf.auto_transfer(vol)
    cam = fit_camera(Camera(size=(64, 64)), vol, tf, 0.0, 100.0)
    clean = fit_camera(Camera(size=(64, 64)), blob_volume(), tf, 0.0, 100.0)
    assert cam.zoom == pytest.approx(clean.zoom, rel=0.05)


def test_cli_render_of_an_off_centre_object_fills_80_percent_for_any_thread_count(tmp_path):
    from PIL import Image

    np.save(tmp_path / "b.npy", blob_volume())
    images = []
    for workers in ("1", "2"):
        out = tmp_path / f"b{workers}.png"
        r = CliRunner().invoke(main, ["render", str(tmp_path / "b.npy"), str(out), "--size",
                                      "80x64", "-j", workers, "--json"])  # fmt: skip
        assert r.exit_code == 0, r.output
        images.append(np.asarray(Image.open(out)))
    np.testing.assert_array_equal(images[0], images[1])
    lit = images[0].max(axis=2) > 12
    rows, cols = np.flatnonzero(lit.any(axis=1)), np.flatnonzero(lit.any(axis=0))
    frac = max((cols[-1] - cols[0] + 1) / 80, (rows[-1] - rows[0] + 1) / 64)
    assert 0.7 <= frac <= 0.88, frac
    r = CliRunner().invoke(main, ["render", str(tmp_path / "b.npy"), str(tmp_path / "n.png"),
                                  "--size", "80x64", "--no-fit"])  # fmt: skip
    assert r.exit_code == 0, r.output
    lit = np.asarray(Image.open(tmp_path / "n.png")).max(axis=2) > 12
    assert lit.any(axis=0).sum() < 0.4 * 80  # the whole grid framed, as before


@pytest.mark.slow  # the animation decoder's kernels: every other animation test is in the slow set
def test_play_frames_an_animation_on_its_first_frame(tmp_path):
    from volpack.animation.stream import compress as compress_animation

    frames = np.stack([blob_volume(n=40, centre=(10, 12 + t, 28), r=5, dtype=np.uint8)
                       for t in range(3)])  # fmt: skip
    src = tmp_path / "a.vpk"
    compress_animation(frames, str(src), gop_string="IP")
    out = tmp_path / "frames"
    r = CliRunner().invoke(main, ["play", str(src), str(out) + "/", "--size", "64x64"])
    assert r.exit_code == 0, r.output
    from PIL import Image

    first = np.asarray(Image.open(sorted(out.iterdir())[0])).max(axis=2) > 12
    cols, rows = np.flatnonzero(first.any(axis=0)), np.flatnonzero(first.any(axis=1))
    assert 0.65 <= max(cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1) / 64 <= 0.9


def test_an_octree_is_framed_on_its_coarse_level(tmp_path):
    from PIL import Image

    from volpack.octree import build

    build(blob_volume(n=72, centre=(20, 50, 24), r=9, dtype=np.uint8), str(tmp_path / "t.vpk"),
          block=8)  # fmt: skip
    for cmd in (["render", str(tmp_path / "t.vpk"), str(tmp_path / "t.png")],
                ["walk", str(tmp_path / "t.vpk"), str(tmp_path / "w") + "/", "--orbit", "2"]):  # fmt: skip
        r = CliRunner().invoke(main, [*cmd, "--size", "64x64"])
        assert r.exit_code == 0, r.output
    for png in [tmp_path / "t.png", *sorted((tmp_path / "w").iterdir())]:
        lit = np.asarray(Image.open(png)).max(axis=2) > 12
        cols, rows = np.flatnonzero(lit.any(axis=0)), np.flatnonzero(lit.any(axis=1))
        assert 0.7 <= max(cols[-1] - cols[0] + 1, rows[-1] - rows[0] + 1) / 64 <= 0.9, png


# --------------------------------------------------------------------------- automatic TF


def test_ct_in_hounsfield_units_is_recognised_from_the_histogram():
    ct = head_like_ct()
    assert autotf.auto_transfer(ct).name == "auto-ct"
    assert autotf.auto_transfer(ct.astype(np.float32)).name == "auto-ct"  # float CT too
    shifted = (ct.astype(np.float32) + 1024) / 4095  # not Hounsfield any more
    assert autotf.auto_transfer(shifted).name == "auto-intensity"


def test_a_label_map_gets_opaque_labels_and_an_empty_background():
    labels = np.zeros((24, 24, 24), np.uint8)
    labels[4:12, 4:20, 4:20] = 3
    labels[12:20, 4:20, 4:20] = 7
    tf = autotf.auto_transfer(labels)
    assert tf.name == "auto-labels"
    rgba = tf(np.array([0.0, 3.0, 7.0]))
    assert rgba[0, 3] == 0 and rgba[1, 3] > 0.5 and rgba[2, 3] > 0.5
    assert np.abs(rgba[1, :3] - rgba[2, :3]).max() > 0.2  # told apart by colour
    mri_like = blob_volume(dtype=np.uint8, noise=3.0)  # integers that vary: not labels
    assert autotf.auto_transfer(np.clip(mri_like, 0, 255)).name == "auto-intensity"


def test_otsu_threshold_separates_background_from_object():
    vol = blob_volume(noise=2.0)
    s = autotf.sample_values(vol)
    t = autotf.otsu(s, float(s.min()), float(s.max()))
    assert 20 < t < 80
    tf = autotf.auto_transfer(vol)
    a = tf(np.array([0.0, 5.0, t - 1, 99.0]))[:, 3]
    assert a[0] == a[1] == a[2] == 0 and a[3] > 0.2


def test_a_signed_field_shows_both_tails_and_a_filled_field_its_minority():
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, 32),) * 3, indexing="ij")
    signed = (np.exp(-((x - 0.5) ** 2 + y**2 + z**2) * 20)
              - np.exp(-((x + 0.5) ** 2 + y**2 + z**2) * 20)).astype(np.float32)  # fmt: skip
    a = autotf.auto_transfer(signed)(np.array([-1.0, 0.0, 1.0]))
    assert a[0, 3] > 0.2 and a[2, 3] > 0.2 and a[1, 3] == 0
    assert a[0, 2] > a[0, 0] and a[2, 0] > a[2, 2]  # blue below zero, red above
    low = (1.0 - np.exp(-((x**2 + y**2) * 30))).astype(np.float32)  # a low-valued core
    tf = autotf.auto_transfer(low)
    assert tf(np.array([0.0]))[0, 3] > 0.2 and tf(np.array([1.0]))[0, 3] == 0


def test_the_plateau_hides_what_lies_behind_a_fixed_share_of_the_volume():
    for n in (64, 256, 1024):
        a = autotf.plateau(n)
        depth = max(2.0, n / 48)
        assert (1 - a) ** depth == pytest.approx(0.05)


def test_transfer_for_keeps_presets_and_files():
    vol = head_like_ct()
    assert autotf.transfer_for("ct-skin", vol, lo=-1000, hi=1200).name == "ct-skin"
    assert autotf.transfer_for(None, vol, lo=-1000, hi=1200).name == "auto-ct"
    assert autotf.transfer_for("auto", vol, lo=-1000, hi=1200).name == "auto-ct"


def _cached(name):
    path = os.path.join(_DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} is not cached (python scripts/fetch_data.py fetches it)")
    return path


def test_real_ct_and_mri_get_their_looks():
    from volpack import io as vio

    mri = vio.read_volume(_cached("brainsmall.den")).data
    tf = autotf.auto_transfer(mri)
    assert tf.name == "auto-intensity"
    a = tf(np.array([0.0, 5.0, 120.0]))[:, 3]
    assert a[0] == a[1] == 0 and a[2] > 0.2  # background clear, head opaque
    ct = vio.read_volume(_cached("Cranium.inv3")).data
    assert autotf.auto_transfer(ct[::2, ::2, ::2]).name == "auto-ct"


# --------------------------------------------------------------------------- meshes


def box_mesh(n=4, scale=(1.0, 1.0, 0.2)):
    from tetra_meshes import grid_mesh

    m = grid_mesh(n)
    return m.points * np.asarray(scale), m.tets


def test_a_mesh_without_fields_is_an_opaque_lit_surface():
    pts, tets = box_mesh()
    cam = fit_mesh_camera(Camera(size=(64, 64), azimuth=30, elevation=35), pts, tets)
    img = render_surface(pts, tets, camera=cam, workers=1)
    assert set(np.unique(img[..., 3])) == {0.0, 1.0}
    assert 0.74 <= span(img) <= 0.84
    # the top face (normal +z) and the side faces are lit differently: a surface look
    shade = img[..., 0][img[..., 3] > 0]
    assert shade.max() - shade.min() > 0.1
    np.testing.assert_array_equal(img, render_surface(pts, tets, camera=cam, workers=2))
    # the silhouette is the one the volume ray caster finds for the same mesh
    tf = TransferFunction(((0.0, 1, 1, 1, 0.5), (1.0, 1, 1, 1, 0.5)))
    vol = render_mesh(pts, tets, np.zeros(len(pts)), tf=tf, camera=cam, value_range=(0, 1))
    differ = (img[..., 3] > 0) != (vol[..., 3] > 0)
    assert differ.sum() <= 0.01 * differ.size


def test_a_mesh_field_colours_the_surface():
    pts, tets = box_mesh()
    field = pts[:, 0]  # x: blue at one end, red at the other
    cam = Camera(size=(64, 64), azimuth=0, elevation=80)
    img = render_surface(pts, tets, field, camera=cam)
    hit = img[..., 3] > 0
    cols = np.flatnonzero(hit.any(axis=0))
    left, right = img[:, cols[1]][hit[:, cols[1]]], img[:, cols[-2]][hit[:, cols[-2]]]
    assert left[:, 2].mean() > left[:, 0].mean() and right[:, 0].mean() > right[:, 2].mean()
    plain = render_surface(pts, tets, np.full(len(pts), 3.0), camera=cam)  # constant: plain
    np.testing.assert_array_equal(plain, render_surface(pts, tets, camera=cam))


def test_cli_renders_a_mesh_without_fields(tmp_path):
    meshio = pytest.importorskip("meshio")
    pts, tets = box_mesh()
    meshio.write(tmp_path / "m.vtu", meshio.Mesh(pts, [("tetra", tets)]))
    r = CliRunner().invoke(main, ["render", str(tmp_path / "m.vtu"), str(tmp_path / "m.png"),
                                  "--size", "48x48", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    report = json.loads(r.stdout)
    assert report["tf"] is None and report["mesh"]["field"] is None
    r = CliRunner().invoke(main, ["render", str(tmp_path / "m.vtu"), str(tmp_path / "n.png"),
                                  "--tf", "generic"])  # fmt: skip
    assert r.exit_code == 2 and "expected a mesh with a point or cell field" in r.output


# --------------------------------------------------------------------------- presets


def documented_presets() -> set[str]:
    """Preset names in the README and in every command's --help: ``--tf NAME`` and the
    lists ``a preset (a, b, c)``."""
    texts = [(ROOT / "README.md").read_text()]
    ctx_cmds = [main.get_command(None, name) for name in main.list_commands(None)]
    import click

    for cmd in ctx_cmds:
        with click.Context(cmd, info_name=cmd.name) as ctx:
            texts.append(cmd.get_help(ctx))
    names = set()
    for text in texts:
        flat = re.sub(r"-\s+", "-", " ".join(text.split()))  # help text wraps at hyphens
        # a name, not a file (``--tf wind.json``)
        names |= set(re.findall(r"--tf ([a-z][a-z0-9-]*)\b(?!\.\w|/)", flat))
        for group in re.findall(r"a preset \(([^)]*)\)", flat):
            names |= {n.strip() for n in group.split(",")}
    return names - {"auto", "my_tf"}  # my_tf: the README's example of a JSON file


def test_every_documented_preset_exists():
    names = documented_presets()
    assert {"ct-bone", "ct-skin", "mri", "generic"} <= names
    missing = names - set(PRESETS)
    assert not missing, f"documented but not presets: {missing}"
    for name in names:
        for lo, hi in [(-1024.0, 3071.0), (0.0, 255.0)]:
            tf = load_tf(name, lo, hi)
            assert tf.name == name and max(p[4] for p in tf.points) > 0


def test_visible_cells_of_integers_match_their_float_copy_and_keep_memory_bounded():
    """The framing's visibility pass reads 8/16-bit voxels through a table of every value
    and classifies at most framing.CHUNK voxels at a time (session 35, rend35: a 1024^3
    uint8 volume took 24 s and 837 MB of float64 copies in fit_camera, 4 s and 4 MB now)."""
    import tracemalloc

    from volpack.render.framing import visible_cells

    rng = np.random.default_rng(35)
    alpha = np.clip(np.linspace(-0.5, 1.0, 256), 0.0, 1.0)
    ramp = np.indices((20, 30, 40)).sum(axis=0) * 255 // 87  # cells below and above the TF
    base = np.clip(ramp + rng.integers(-20, 21, ramp.shape), 0, 255)
    for a, lo, hi in ((base.astype(np.uint8), 0.0, 255.0), ((base * 97 - 12000).astype(np.int16), -9000.0, 9000.0),
                      ((base * 97 - 12000).astype(">i2"), -9000.0, 9000.0), (base > 200, 0.0, 1.0),
                      ((base - 128).astype(np.int8), -60.0, 100.0)):  # fmt: skip
        mask = rng.random(a.shape) > 0.8
        for m in (None, mask):
            got = visible_cells(a, alpha, lo, hi, mask=m, cells=8)
            ref = visible_cells(a.astype(np.float32), alpha, lo, hi, mask=m, cells=8)
            assert got[1] == ref[1] and np.array_equal(got[0], ref[0]), a.dtype
            assert got[0].any() and not got[0].all()
    big = np.zeros((64, 512, 512), np.uint8)
    big[20:40, 100:300, 200:400] = 200
    tracemalloc.start()
    vis, block = visible_cells(big, alpha, 0.0, 255.0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < big.nbytes / 4, peak  # base: about 5x the volume in float64 slabs
    idx = np.argwhere(vis)
    assert (idx.min(axis=0) * block <= (20, 100, 200)).all() and (
        (idx.max(axis=0) + 1) * block >= (40, 300, 400)
    ).all()
