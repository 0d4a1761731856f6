"""zarr stores as input: plain arrays (formats 2 and 3), OME-Zarr images with their
levels and geometry, the octree builder reading box by box, and the errors."""

from __future__ import annotations

import sys

import numpy as np
import pytest

from volpack import api
from volpack import io as vio
from volpack.errors import FormatError
from volpack.volume import Volume

zarr = pytest.importorskip("zarr")


def _ramp(shape=(6, 7, 9), dtype=np.int16) -> np.ndarray:
    return (np.arange(np.prod(shape)) * 7 % 1001 - 300).astype(dtype).reshape(shape)


@pytest.mark.parametrize("fmt", [2, 3])
def test_zarr_array_reads_bit_for_bit(tmp_path, fmt):
    a = _ramp()
    path = str(tmp_path / "a.zarr")
    z = zarr.create_array(path, shape=a.shape, chunks=(2, 4, 4), dtype=a.dtype, zarr_format=fmt)
    z[...] = a
    vol = vio.read_volume(path)
    np.testing.assert_array_equal(vol.data, a)
    assert vol.dtype == a.dtype and vol.meta["source_format"] == "zarr"
    assert vio.detect_format(path) == "zarr"
    head = vio.read_header(path)
    assert head["shape"] == list(a.shape) and head["dtype"] == "int16"


def _ome(path: str, a: np.ndarray, version: str) -> None:
    """An OME-Zarr image (t, c, z, y, x) of one time point and channel, two levels."""
    fmt = 3 if version == "0.5" else 2
    g = zarr.open_group(path, mode="w", zarr_format=fmt)
    for level, f in enumerate((1, 2)):
        part = a[::f, ::f, ::f]
        arr = g.create_array(
            str(level), shape=(1, 1, *part.shape), chunks=(1, 1, 2, 4, 4), dtype=a.dtype
        )
        arr[...] = part[None, None]
    levels = [
        {"path": "0", "coordinateTransformations": [
            {"type": "scale", "scale": [1, 1, 2.0, 0.5, 0.25]},
            {"type": "translation", "translation": [0, 0, 5.0, -1.0, 3.0]}]},
        {"path": "1", "coordinateTransformations": [
            {"type": "scale", "scale": [1, 1, 4.0, 1.0, 0.5]}]},
    ]  # fmt: skip
    multiscales = [
        {
            "version": version,
            "datasets": levels,
            "axes": [
                {"name": n, "type": t} for n, t in zip("tczyx", ["time", "channel", *["space"] * 3])
            ],
        }
    ]
    if version == "0.5":
        g.attrs["ome"] = {"version": version, "multiscales": multiscales}
    else:
        g.attrs["multiscales"] = multiscales


@pytest.mark.parametrize("version", ["0.4", "0.5"])
def test_ome_zarr_reads_its_finest_level_with_geometry(tmp_path, version):
    a = _ramp((8, 9, 10))
    path = str(tmp_path / "img.zarr")
    _ome(path, a, version)
    vol = vio.read_volume(path)
    np.testing.assert_array_equal(vol.data, a)  # (1, 1, z, y, x) -> (z, y, x)
    assert vol.spacing == (2.0, 0.5, 0.25) and vol.origin == (5.0, -1.0, 3.0)
    coarse = vio.read_volume(path + ":/1")
    np.testing.assert_array_equal(coarse.data, a[::2, ::2, ::2])
    assert coarse.spacing == (4.0, 1.0, 0.5) and coarse.meta["zarr_array"] == "/1"
    assert vio.read_header(path)["spacing"] == [2.0, 0.5, 0.25]


def test_zarr_group_without_image_names_its_arrays(tmp_path):
    path = str(tmp_path / "g.zarr")
    g = zarr.open_group(path, mode="w")
    for name in ("pressure", "density"):
        g.create_array(name, shape=(3, 4, 5), dtype="f4")[...] = 1.0
    with pytest.raises(FormatError, match=r"found (pressure, density|density, pressure)"):
        vio.read_volume(path)
    assert vio.read_volume(path + ":density").shape == (3, 4, 5)
    assert [a["name"] for a in vio.list_arrays(path)] == ["/density", "/pressure"]
    with pytest.raises(FormatError, match="expected an array 'nope'"):
        vio.read_volume(path + ":/nope")
    g.create_array("line", shape=(5,), dtype="f4")
    with pytest.raises(FormatError, match="expected a 2-D, 3-D"):
        vio.read_volume(path + ":line")


def test_zarr_missing_library_names_the_extra(tmp_path, monkeypatch):
    path = str(tmp_path / "a.zarr")
    zarr.create_array(path, shape=(2, 3, 4), dtype="u1")
    monkeypatch.setitem(sys.modules, "zarr", None)  # as if not installed
    with pytest.raises(FormatError, match=r"volpack\[zarr\]"):
        vio.read_volume(path)


@pytest.mark.slow
def test_zarr_store_builds_an_octree_box_by_box(tmp_path):
    a = _ramp((40, 36, 33), np.uint16)
    path = str(tmp_path / "big.zarr")
    zarr.create_array(path, shape=a.shape, chunks=(16, 16, 16), dtype=a.dtype)[...] = a
    out = str(tmp_path / "o.vpk")
    api.compress(path, out, kind="octree", block=16)
    np.testing.assert_array_equal(api.decompress(out, level=0).data, a)


@pytest.mark.parametrize("shape", [(6, 7, 9), (3, 6, 7, 9)])
def test_zarr_output_is_an_ome_image_that_reads_back(tmp_path, shape):
    a = _ramp(shape, np.float32) / 3
    vol = Volume(a, spacing=(2.5, 1.0, 0.5), origin=(1.0, 2.0, -3.0), meta={"units": "mm"})
    path = str(tmp_path / "out.zarr")
    vio.write_volume(vol, path)
    back = vio.read_volume(path)
    np.testing.assert_array_equal(back.data, a)
    assert back.spacing == vol.spacing and back.origin == vol.origin
    assert back.meta["units"] == "mm"
    ome = zarr.open_group(path, mode="r").attrs["ome"]  # what viewers read
    assert ome["multiscales"][0]["datasets"][0]["path"] == "0"
    assert [ax["name"] for ax in ome["multiscales"][0]["axes"]][-3:] == ["z", "y", "x"]


def test_zarr_output_replaces_only_with_force_and_never_half_written(tmp_path, monkeypatch):
    path = str(tmp_path / "out.zarr")
    first = _ramp()
    vio.write_volume(first, path)
    with pytest.raises(FileExistsError):
        vio.write_volume(first * 2, path)

    def broken(*args, **kwargs):
        raise OSError("disk full")

    real = zarr.open_group
    monkeypatch.setattr(zarr, "open_group", broken)
    with pytest.raises(FormatError, match="disk full"):
        vio.write_volume(first * 2, path, force=True)
    monkeypatch.setattr(zarr, "open_group", real)
    np.testing.assert_array_equal(vio.read_volume(path).data, first)  # the old one intact
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.zarr"]  # nothing left behind
    stale = tmp_path / ".volpack-999999999-0123abcd.part"  # a dead writer's folder
    (stale / "0").mkdir(parents=True)
    kept = tmp_path / ".volpack-999999999-4567abcd.old"  # an output it had set aside
    kept.mkdir()
    vio.write_volume(first * 2, path, force=True)
    np.testing.assert_array_equal(vio.read_volume(path).data, first * 2)
    assert not stale.exists() and kept.exists()
    kept.rmdir()
    with pytest.raises(FormatError, match="whole zarr store"):
        vio.write_volume(first, path + ":/x", force=True)
