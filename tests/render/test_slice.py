"""The slice view: a volume one voxel thick drawn face-on as the 2-D image it is, against
a per-pixel reference, and `volpack render`'s choice between it and ray casting."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner

from volpack.cli import main
from volpack.errors import OptionError
from volpack.render.slice import render_slice, slice_axis, slice_transfer
from volpack.render.transfer import TransferFunction
from volpack.volume import Volume

GREY = TransferFunction(((0.0, 0.0, 0.0, 0.0, 0.5), (10.0, 1.0, 1.0, 1.0, 0.5)), "grey")


def reference(plane, s_rows, s_cols, w, h, zoom=1.0):
    """Values at pixel centres, pixel by pixel: the pixel's world point on the plane (cells
    of one spacing, fitted to the tighter side, first row at the bottom), bilinear between
    the four voxel centres around it (clamped at the edges), NaN outside."""
    nr, nc = plane.shape
    scale = min(w / (nc * s_cols), h / (nr * s_rows)) * zoom
    out = np.full((h, w), np.nan)
    for i in range(h):
        for j in range(w):
            x = (j + 0.5 - w / 2) / scale + nc * s_cols / 2
            y = (h / 2 - i - 0.5) / scale + nr * s_rows / 2
            if not (0 <= x < nc * s_cols and 0 <= y < nr * s_rows):
                continue
            u = min(max(x / s_cols - 0.5, 0), nc - 1)
            v = min(max(y / s_rows - 0.5, 0), nr - 1)
            r0, c0 = int(np.floor(v)), int(np.floor(u))
            r1, c1 = min(r0 + 1, nr - 1), min(c0 + 1, nc - 1)
            tr, tc = v - r0, u - c0
            out[i, j] = ((1 - tr) * ((1 - tc) * plane[r0, c0] + tc * plane[r0, c1])
                         + tr * ((1 - tc) * plane[r1, c0] + tc * plane[r1, c1]))  # fmt: skip
    return out


@pytest.mark.parametrize(
    "shape, spacing, size, zoom",
    [((1, 6, 9), (1.0, 1.0, 1.0), (9, 6), 1.0),  # a pixel a voxel: the voxels themselves
     ((1, 5, 7), (3.0, 2.0, 1.0), (40, 24), 1.0),  # anisotropic, letterboxed
     ((7, 1, 5), (0.5, 1.0, 1.0), (33, 17), 1.7),  # thin along y, zoomed in
     ((4, 6, 1), (1.0, 1.0, 1.0), (20, 20), 0.6)],  # thin along x, zoomed out
)  # fmt: skip
def test_the_slice_is_the_plane_sampled_at_each_pixel(shape, spacing, size, zoom):
    data = np.random.default_rng(3).uniform(0, 10, shape).astype(np.float32)
    img = render_slice(Volume(data, spacing=spacing), GREY, value_range=(0, 10), size=size,
                       zoom=zoom)  # fmt: skip
    axis = shape.index(1)
    rows, cols = (k for k in range(3) if k != axis)
    ref = reference(np.take(data, 0, axis).astype(np.float64), spacing[rows], spacing[cols],
                    *size, zoom)  # fmt: skip
    assert img.shape == (size[1], size[0], 4)
    shown = ~np.isnan(ref)
    assert shown.any() and np.array_equal(img[..., 3] > 0, shown)
    assert np.allclose(img[shown, 0], ref[shown] / 10.0, atol=1e-6)  # grey: alpha 1 (0.5 / 0.5)
    assert np.all(img[~shown] == 0)
    if size == shape[1:][::-1]:  # one pixel a voxel, the first row at the bottom
        assert np.allclose(img[::-1, :, 0], data[0] / 10.0, atol=1e-6)


def test_empty_voxels_are_black_and_do_not_spread():
    data = np.arange(64, dtype=np.float32).reshape(1, 8, 8)
    data[0, 3, 4] = np.nan
    mask = np.zeros(data.shape, bool)
    mask[0, 6, 1] = True
    img = render_slice(Volume(data, mask=mask), GREY, value_range=(0, 63), size=(32, 32))
    assert np.isfinite(img).all()
    up = img[::-1]  # the first row at the bottom: flip to index rows as the data
    assert np.all(up[12:16, 16:20] == 0) and np.all(up[24:28, 4:8] == 0)
    assert up[12:16, 20:24, 3].min() == 1 and up[16:20, 16:20, 3].min() == 1
    # pixels whose nearest voxel is valid but whose neighbours include the NaN voxel take
    # the weighted mean of the valid ones: finite, inside the range, not black
    assert np.all((up[11:17, 15:21, 0] == 0) == (up[11:17, 15:21, 3] == 0))
    assert 0 < up[16, 19, 0] <= 1 and 0 < up[12, 20, 0] <= 1


def test_opacity_is_scaled_to_the_tf_peak_and_a_clear_tf_draws_nothing():
    data = np.full((1, 4, 4), 5.0, np.float32)
    faint = TransferFunction(((0.0, 1.0, 0.5, 0.0, 0.0), (10.0, 1.0, 0.5, 0.0, 0.02)))
    img = render_slice(data, faint, value_range=(0, 10), size=(4, 4))
    assert np.allclose(img[..., 3], 0.5) and np.allclose(img[..., 1], 0.25)
    clear = TransferFunction(((0.0, 1.0, 1.0, 1.0, 0.0),))
    assert not render_slice(data, clear, value_range=(0, 10), size=(4, 4)).any()


def test_labels_are_drawn_nearest_and_never_blended():
    labels = np.zeros((1, 32, 32), np.uint8)
    labels[0, :, 16:] = 7
    labels[0, 8:24, 8:24] = 3
    tf = slice_transfer(labels)
    assert tf.name == "auto-labels"
    img = render_slice(labels, tf, value_range=(0, 7), size=(45, 45), nearest=True)
    colours = {tuple(np.round(c, 5)) for c in img.reshape(-1, 4)}
    assert len(colours) == 3  # background, label 3, label 7: nothing in between


def test_slice_colourings_follow_the_data():
    rng = np.random.default_rng(0)
    ct = np.full((1, 40, 40), -1000, np.int16)
    ct[0, 10:30, 10:30] = 40
    ct[0, 14:16, 10:30] = 1200
    assert slice_transfer(ct).name == "slice-grey"
    signed = rng.normal(0, 1, (1, 40, 40)).astype(np.float32)
    assert slice_transfer(signed).name == "slice-diverging"
    field = (20 + np.linspace(0, 5, 1600)).reshape(1, 40, 40).astype(np.float32)
    assert slice_transfer(field).name == "slice-field"
    nan = np.full((1, 3, 3), np.nan, np.float32)
    assert not render_slice(nan, slice_transfer(nan), value_range=(0, 1), size=(8, 8)).any()


def test_slice_axis_and_bad_requests():
    assert slice_axis((5, 1, 3)) == 1 and slice_axis((9, 4, 6)) == 1 and slice_axis((1, 1, 3)) == 0
    data = np.zeros((3, 4, 5), np.float32)
    with pytest.raises(OptionError, match="slice index in 0..2, found 3"):
        render_slice(data, GREY, value_range=(0, 1), axis=0, index=3)
    with pytest.raises(OptionError, match="3-D volume"):
        render_slice(np.zeros((4, 5)), GREY, value_range=(0, 1))


def _render(tmp_path, data, *args):
    np.save(tmp_path / "v.npy", data)
    out = tmp_path / "v.png"
    r = CliRunner().invoke(main, ["-q", "render", str(tmp_path / "v.npy"), str(out),
                                  "--size", "64x48", "--json", *args])  # fmt: skip
    return r, out


def test_cli_draws_a_single_slice_face_on(tmp_path):
    from PIL import Image

    data = np.linspace(0, 1, 30 * 20, dtype=np.float32).reshape(1, 20, 30)
    r, out = _render(tmp_path, data)
    assert r.exit_code == 0, r.output
    report = json.loads(r.stdout)
    assert report["view"] == "slice" and report["slice"] == {"axis": 0, "index": 0}
    img = np.asarray(Image.open(out))
    assert img.shape == (48, 64, 3)
    lit = np.nonzero(img.max(axis=(1, 2)))[0]
    assert len(lit) >= 40  # 64x48 letterboxes a 30x20 plane to 64x43 pixels, not a sliver


def test_cli_view_slice_of_a_thick_volume_and_its_errors(tmp_path):
    data = np.random.default_rng(1).uniform(0, 1, (6, 9, 7)).astype(np.float32)
    r, _ = _render(tmp_path, data, "--view", "slice", "--force")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["slice"] == {"axis": 0, "index": 3}
    r, _ = _render(tmp_path, data, "--view", "slice", "--iso", "0.5:bone", "--force")
    assert r.exit_code != 0 and "--view slice" in r.output


def test_play_draws_a_2d_series_face_on(tmp_path):
    from PIL import Image

    t = np.arange(3, dtype=np.float32)[:, None, None, None]
    series = np.sin(np.linspace(0, 3, 24 * 16, dtype=np.float32)).reshape(1, 1, 16, 24) + t
    np.save(tmp_path / "s.npy", series)
    out = tmp_path / "frames"
    r = CliRunner().invoke(main, ["-q", "play", str(tmp_path / "s.npy"), str(out) + "/",
                                  "--size", "48x32", "--json"])  # fmt: skip
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["view"] == "slice"
    frames = [np.asarray(Image.open(p)) for p in sorted(out.iterdir())]
    assert len(frames) == 3 and all(f[..., :3].max(axis=2).astype(bool).all() for f in frames)
    assert frames[0].tobytes() != frames[2].tobytes()  # one TF for all: later steps differ
    r = CliRunner().invoke(main, ["play", str(tmp_path / "s.npy"), "--view", "slice",
                                  "--spin", "5"])  # fmt: skip
    assert r.exit_code != 0 and "--spin" in r.output


def test_a_constant_volume_is_shown_not_black():
    from volpack.render.autotf import auto_transfer

    flat = np.full((1, 6, 8), 7.0, np.float32)
    img = render_slice(flat, slice_transfer(flat), value_range=(7.0, 8.0), size=(8, 6))
    assert np.allclose(img[..., :3], 0.5) and np.all(img[..., 3] == 1)
    block = np.full((8, 8, 8), 7.0, np.float32)  # the 3-D look: the block it fills, lit
    assert auto_transfer(block, value_range=(7.0, 8.0))(7.0)[3] > 0.1
