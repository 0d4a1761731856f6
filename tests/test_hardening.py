"""Inputs that used to change meaning or crash: bool volumes, meshes without tets or
fields, headers whose values pass the checksums but not the types, huge spacings,
volumes with an axis of length 0."""

from __future__ import annotations

import io

import numpy as np
import pytest
from click.testing import CliRunner
from conftest import rewrite_header

from volpack import api
from volpack.cli import main
from volpack.errors import FormatError


def _cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _one_line_error(r):
    lines = [ln for ln in r.output.splitlines() if ln.strip()]
    assert r.exit_code == 1 and len(lines) == 1 and lines[0].startswith("volpack: error: "), (
        r.exit_code,
        r.output,
    )
    return lines[0]


def test_a_bool_volume_comes_back_as_bool(tmp_path):
    a = np.random.default_rng(0).random((9, 10, 11)) > 0.6
    np.save(tmp_path / "b.npy", a)
    assert _cli("compress", tmp_path / "b.npy", tmp_path / "b.vpk").exit_code == 0
    assert _cli("decompress", tmp_path / "b.vpk", tmp_path / "c.npy").exit_code == 0
    c = np.load(tmp_path / "c.npy")
    assert c.dtype == bool and (c == a).all()


@pytest.mark.parametrize(
    "shape, args",
    [
        ((0, 3, 4), ()),
        ((5, 0, 4), ("--codec", "fast")),
        ((5, 3, 0), ("--max-error", "0.1")),
        ((2, 3, 0, 5), ()),
        ((3, 4, 0, 5), ("--gop", "IPP")),
        ((0, 4, 4, 5), ("--gop", "IPP")),
    ],
)
def test_a_volume_without_voxels_is_refused(tmp_path, shape, args):
    np.save(tmp_path / "e.npy", np.zeros(shape, np.float32))
    line = _one_line_error(_cli("compress", tmp_path / "e.npy", tmp_path / "e.vpk", *args))
    assert "at least one voxel" in line and str(shape) in line, line
    assert not (tmp_path / "e.vpk").exists()
    with pytest.raises(FormatError, match="at least one voxel"):
        api.compress_array(np.zeros(shape, np.uint8))


def test_a_mesh_without_tetrahedra_is_refused(tmp_path):
    meshio = pytest.importorskip("meshio")
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    meshio.write(tmp_path / "s.vtu", meshio.Mesh(pts, [("triangle", np.array([[0, 1, 2]]))]))
    r = _cli("compress", tmp_path / "s.vtu", tmp_path / "s.vpk")
    msg = r.output.strip().splitlines()[-1]  # after a warning about the dropped triangles
    assert r.exit_code == 1 and msg.startswith("volpack: error: ")
    assert "tetrahedra" in msg and "triangle" in msg
    assert not (tmp_path / "s.vpk").exists()


def test_a_mesh_without_fields_renders_its_shape(tmp_path):
    from tetra_meshes import grid_mesh

    from volpack.tetra.stream import compress_mesh

    compress_mesh(grid_mesh(3), str(tmp_path / "m.vpk"))  # points and tets, no field
    r = _cli("render", tmp_path / "m.vpk", tmp_path / "m.png", "--size", "32x32")
    assert r.exit_code == 0, r.output
    from PIL import Image

    img = np.asarray(Image.open(tmp_path / "m.png"))
    assert img[..., :3].max() > 0  # something is drawn


@pytest.fixture(scope="module")
def stream():
    a = (np.arange(6 * 7 * 8) % 13).reshape(6, 7, 8).astype(np.uint8)
    return api.compress_array(a)


@pytest.mark.parametrize(
    "field, value, words",
    [
        ("spacing", None, "spacing"),
        ("spacing", [1.0, 0.0, 1.0], "positive"),
        ("spacing", [1e308, 1, 1], "spacing"),
        ("origin", None, "origin"),
        ("origin", ["a", 0, 0], "origin"),
        ("shape", {}, "shape"),
        ("shape", None, "shape"),
        ("shape", [2**31, 2**31, 2**31], "limit"),
        ("dtype", "O", "dtype"),
        ("codec", {"id": "wavelet", "wavelet": 53}, "wavelet"),
        (
            "codec",
            {
                "id": "bounded",
                "max_error": 1e308,
                "lo": 0,
                "step": "x",
                "integer": True,
                "qdtype": "uint8",
            },
            "step",
        ),  # fmt: skip
        ("codec", "zstd", "codec"),
    ],
)
def test_bad_header_values_give_one_line_errors(stream, tmp_path, field, value, words):
    bad = tmp_path / "bad.vpk"
    bad.write_bytes(rewrite_header(stream, **{field: value}))
    with pytest.raises(FormatError, match=words):
        api.decompress(str(bad))
    for cmd in (["decompress", bad, tmp_path / "o.npy"], ["render", bad, tmp_path / "o.png"]):
        _one_line_error(_cli(*cmd))


def test_a_shape_that_disagrees_with_the_chunks_is_refused_before_allocating(stream, tmp_path):
    # a fuzz find: 8 chunks under a header shape of 20 x 24 x 3,670,016 made the decoder list
    # 917,504 bricks and reserve 1.7 GB before the first brick failed (10 s); the count of
    # chunks now settles it first, from a file and from a pipe alike
    bad = rewrite_header(stream, shape=[20, 24, 3670016], brick=[16, 16, 16])
    with pytest.raises(FormatError, match="expected 917504 chunks .* found 1"):
        api.decompress(bad)
    with pytest.raises(FormatError, match="expected 917504 chunks"):
        api.decompress(io.BytesIO(bad))
    path = tmp_path / "bad.vpk"
    path.write_bytes(bad)
    _one_line_error(_cli("render", path, tmp_path / "o.png", "--size", "16x16"))
    r = CliRunner().invoke(main, ["decompress", "-", str(tmp_path / "o.npy")], input=bad)
    _one_line_error(r)


def test_info_on_a_bad_shape_is_an_error(stream, tmp_path):
    for shape in ({}, None, "x"):
        bad = tmp_path / "bad.vpk"
        bad.write_bytes(rewrite_header(stream, shape=shape))
        _one_line_error(_cli("info", bad))


def test_a_huge_spacing_never_crashes_the_renderer():
    from volpack.render.camera import Camera
    from volpack.render.raycast import render
    from volpack.render.transfer import preset

    a = np.linspace(0, 1, 64, dtype=np.float32).reshape(4, 4, 4)
    cam, tf = Camera(size=(8, 8)), preset("generic", 0, 1)
    for sp in (1e300, 1e-300, 1.7e308):
        img = render(a, spacing=(sp,) * 3, tf=tf, camera=cam, value_range=(0, 1))
        assert np.isfinite(img).all() and img[..., 3].max() > 0, sp  # the ratios matter only
