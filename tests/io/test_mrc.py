"""MRC / CCP4 maps: axes turned to (z, y, x) whatever order the header names, geometry
from the voxel size and origin, compressed maps, volume stacks, writes and errors."""

from __future__ import annotations

import bz2
import gzip
import sys

import numpy as np
import pytest

from volpack import api
from volpack import io as vio
from volpack.errors import FormatError
from volpack.volume import Volume

mrcfile = pytest.importorskip("mrcfile")


def _map(dtype=np.float32, shape=(5, 6, 7)) -> np.ndarray:
    rng = np.random.default_rng(3)
    if np.dtype(dtype).kind == "f":
        return rng.standard_normal(shape).astype(dtype)
    info = np.iinfo(dtype)
    return rng.integers(info.min, info.max, shape, endpoint=True, dtype=dtype)


@pytest.mark.parametrize("dtype", [np.int8, np.int16, np.uint16, np.float16, np.float32])
def test_mrc_round_trip_keeps_values_and_geometry(tmp_path, dtype):
    a = _map(dtype)
    path = str(tmp_path / "m.mrc")
    vio.write_volume(Volume(a, spacing=(3.0, 2.0, 1.5), origin=(10.0, -4.0, 2.5)), path)
    vol = vio.read_volume(path)
    assert vol.dtype == dtype
    np.testing.assert_array_equal(vol.data.view(np.uint8), a.view(np.uint8))
    assert vol.spacing == (3.0, 2.0, 1.5) and vol.origin == (10.0, -4.0, 2.5)
    head = vio.read_header(path)
    assert head["shape"] == [5, 6, 7] and head["spacing"] == [3.0, 2.0, 1.5]
    with mrcfile.open(path) as m:  # what other tools read: x, y, z in MRC2014's order
        assert (m.header.nx, m.header.ny, m.header.nz) == (7, 6, 5)
        assert float(m.voxel_size.x) == 1.5 and float(m.header.origin.z) == 10.0


def test_mrc_uint8_is_stored_as_uint16_and_other_types_refused(tmp_path):
    a = _map(np.uint8)
    vio.write_volume(a, str(tmp_path / "u8.map"))
    back = vio.read_volume(str(tmp_path / "u8.map"))
    assert back.dtype == np.uint16
    np.testing.assert_array_equal(back.data, a)
    for dtype in (np.int32, np.float64):
        with pytest.raises(FormatError, match=f"MRC map, found {np.dtype(dtype).name}"):
            vio.write_volume(_map(np.float32).astype(dtype), str(tmp_path / "x.mrc"))
        assert not (tmp_path / "x.mrc").exists()


@pytest.mark.parametrize("order", [(2, 1, 3), (3, 1, 2), (1, 3, 2), (3, 2, 1)])
def test_mrc_axis_order_of_the_header_gives_z_y_x(tmp_path, order):
    """A crystallographic map stores columns, rows and sections along the axes mapc,
    mapr, maps name; the volume must come back with z, y, x as space has them."""
    zyx = np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)  # z=4, y=5, x=6
    mapc, mapr, maps = order
    # stored[s, r, c] = zyx at the spatial position those indices name
    perm = tuple(3 - a for a in (maps, mapr, mapc))  # zyx axes stored as sections, rows, cols
    stored = np.ascontiguousarray(zyx.transpose(perm))
    path = str(tmp_path / "c.ccp4")
    with mrcfile.new(path) as m:
        m.set_data(stored)
        m.header.mapc, m.header.mapr, m.header.maps = mapc, mapr, maps
        m.header.nxstart, m.header.nystart, m.header.nzstart = 2, 3, 4  # cols, rows, secs
        m.voxel_size = (0.5, 0.25, 2.0)  # x, y, z
    vol = vio.read_volume(path)
    np.testing.assert_array_equal(vol.data, zyx)
    assert vol.spacing == (2.0, 0.25, 0.5)
    start = {mapc: 2, mapr: 3, maps: 4}  # spatial axis (1 x, 2 y, 3 z) -> start index
    assert vol.origin == (start[3] * 2.0, start[2] * 0.25, start[1] * 0.5)
    assert vol.meta["mrc_axis_order"] == list(order)
    assert vio.read_header(path)["shape"] == [4, 5, 6]


@pytest.mark.parametrize("suffix, opener", [(".map.gz", gzip.open), (".mrc.bz2", bz2.open)])
def test_mrc_compressed_maps_read(tmp_path, suffix, opener):
    a = _map(np.float32)
    plain = tmp_path / "p.mrc"
    vio.write_volume(a, str(plain))
    packed = tmp_path / f"p{suffix}"
    with opener(packed, "wb") as f:
        f.write(plain.read_bytes())
    np.testing.assert_array_equal(vio.read_volume(str(packed)).data, a)
    assert vio.read_header(str(packed))["shape"] == list(a.shape)


def test_mrc_volume_stack_reads_as_time_series(tmp_path):
    a = _map(np.float32, (3, 4, 5, 6))
    path = str(tmp_path / "s.mrc")
    with mrcfile.new(path) as m:
        m.set_data(a)
        assert m.is_volume_stack()
    vol = vio.read_volume(path)
    np.testing.assert_array_equal(vol.data, a)
    assert vio.read_header(path)["shape"] == [3, 4, 5, 6]


def test_mrc_damage_and_missing_library_give_one_line_errors(tmp_path, monkeypatch):
    path = tmp_path / "m.mrc"
    vio.write_volume(_map(np.float32), str(path))
    cut = tmp_path / "cut.mrc"
    cut.write_bytes(path.read_bytes()[:1100])
    with pytest.raises(FormatError, match="could not read mrc file"):
        vio.read_volume(str(cut))
    bad = tmp_path / "bad.map"
    bad.write_bytes(b"\x00" * 2048)
    with pytest.raises(FormatError, match="could not read mrc file"):
        vio.read_volume(str(bad))
    monkeypatch.setitem(sys.modules, "mrcfile", None)  # as if not installed
    with pytest.raises(FormatError, match=r"volpack\[mrc\]"):
        vio.read_volume(str(path))


def test_mrc_compresses_and_decodes_back_to_a_map(tmp_path):
    a = _map(np.float32, (9, 10, 11))
    src, packed, out = (str(tmp_path / n) for n in ("in.map", "m.vpk", "out.mrc"))
    vio.write_volume(Volume(a, spacing=(1.1, 1.1, 1.1)), src)
    api.compress(src, packed)
    vio.write_volume(api.decompress(packed), out)
    back = vio.read_volume(out)
    np.testing.assert_array_equal(back.data.view(np.uint32), a.view(np.uint32))
    assert back.spacing == pytest.approx((1.1, 1.1, 1.1))
