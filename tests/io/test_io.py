"""External formats: round trips, orientation, spacing, stdin/stdout, errors, atomicity."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest
from conftest import need

from volpack import io as vio
from volpack.errors import FormatError
from volpack.format.atomic import OutputExistsError
from volpack.volume import Volume

SHAPE = (3, 5, 7)  # non-cubic: a transposition changes the shape
SPACING = (2.5, 0.75, 0.5)
ORIGIN = (-4.0, 10.0, 3.5)
DTYPES = [np.uint8, np.int16, np.uint16, np.float32]
# (file name, keeps spacing and origin)
WRITABLE = [
    ("v.npy", False),
    ("v.raw", False),
    ("v.nii", True),
    ("v.nii.gz", True),
    ("v.nrrd", True),
    ("v.h5", True),
    ("v.h5:/group/vol", True),
    ("v.tif", True),
    ("v.mha", True),
    ("v.mhd", True),
    ("v.vti", True),
    ("v.inr", True),
    ("v.inr.gz", True),
]


def _ramp(dtype, shape=SHAPE) -> np.ndarray:
    """Distinct values along every axis so any axis swap or flip is caught."""
    z, y, x = np.indices(shape)
    a = z * 50 + y * 7 + x
    if np.dtype(dtype).kind == "f":
        return (a * 0.25 - 3.5).astype(dtype)
    if np.dtype(dtype).kind == "i":
        a = a - 60
    return a.astype(dtype)


def _raw_kw(name: str, dtype) -> dict:
    return {"shape": SHAPE, "dtype": np.dtype(dtype).name} if name.endswith(".raw") else {}


@pytest.mark.parametrize("dtype", DTYPES, ids=lambda d: np.dtype(d).name)
@pytest.mark.parametrize(("name", "geometry"), WRITABLE, ids=[w[0] for w in WRITABLE])
def test_round_trip(tmp_path, name, geometry, dtype):
    a = _ramp(dtype)
    spec = str(tmp_path / name)
    vio.write_volume(Volume(a, spacing=SPACING, origin=ORIGIN), spec)
    vol = vio.read_volume(spec, **_raw_kw(name, dtype))
    assert vol.shape == SHAPE
    assert vol.dtype == np.dtype(dtype)
    assert vol.data.flags.c_contiguous and vol.data.dtype.isnative
    np.testing.assert_array_equal(vol.data, a)
    if geometry:
        np.testing.assert_allclose(vol.spacing, SPACING)
        np.testing.assert_allclose(vol.origin, ORIGIN)
    else:
        assert vol.spacing == (1.0, 1.0, 1.0)
    hdr = vio.read_header(spec, **_raw_kw(name, dtype))
    assert hdr["shape"] == list(vol.shape)
    assert hdr["dtype"] == str(vol.dtype)
    np.testing.assert_allclose(hdr["spacing"], vol.spacing)
    np.testing.assert_allclose(hdr["origin"], vol.origin)


@pytest.mark.parametrize("name", ["v.nii.gz", "v.nrrd", "v.h5", "v.tif", "v.npy"])
def test_round_trip_4d(tmp_path, name):
    a = np.stack([_ramp(np.int16) + 100 * t for t in range(2)])  # (t, z, y, x)
    spec = str(tmp_path / name)
    vio.write_volume(Volume(a, spacing=SPACING), spec)
    vol = vio.read_volume(spec)
    assert vol.shape == (2, *SHAPE)
    np.testing.assert_array_equal(vol.data, a)
    if name != "v.npy":
        np.testing.assert_allclose(vol.spacing, SPACING)
    assert vio.read_header(spec)["shape"] == [2, *SHAPE]


@pytest.mark.parametrize("dtype", [np.int8, np.uint32, np.int64, np.float64])
@pytest.mark.parametrize("name", ["v.npy", "v.nii.gz", "v.nrrd", "v.h5", "v.tif"])
def test_wide_dtypes(tmp_path, name, dtype):
    a = _ramp(dtype)
    vio.write_volume(a, str(tmp_path / name))
    vol = vio.read_volume(str(tmp_path / name))
    assert vol.dtype == np.dtype(dtype)
    np.testing.assert_array_equal(vol.data, a)


def test_float16_refused_where_unsupported(tmp_path):
    for name in ("v.nii", "v.nrrd"):
        with pytest.raises(FormatError, match="found float16"):
            vio.write_volume(_ramp(np.float16), str(tmp_path / name))
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("name", ["v.nii", "v.nrrd", "v.h5", "v.tif"])
def test_meta_travels(tmp_path, name):
    meta = {"quantize": {"bits": 12, "scale": 0.5, "offset": -3.0}}
    spec = str(tmp_path / name)
    vio.write_volume(Volume(_ramp(np.uint16), meta=meta), spec)
    vol = vio.read_volume(spec)
    assert vol.meta["quantize"] == meta["quantize"]
    assert vol.meta["source_format"] in name.replace("nii", "nifti").replace("h5", "hdf5").replace(
        "tif", "tiff"
    )


def test_nifti_orientation_matches_nibabel(tmp_path):
    """A file made by nibabel (x, y, z) comes back as (z, y, x) with reversed zooms."""
    nib = pytest.importorskip("nibabel")
    xyz = _ramp(np.int16).transpose(2, 1, 0).copy()  # (7, 5, 3) = (x, y, z)
    img = nib.Nifti1Image(xyz, np.diag([0.5, 0.75, 2.5, 1.0]))
    img.to_filename(str(tmp_path / "n.nii"))
    vol = vio.read_volume(str(tmp_path / "n.nii"))
    np.testing.assert_array_equal(vol.data, _ramp(np.int16))
    assert vol.spacing == SPACING
    # and back: what we write, nibabel sees in (x, y, z)
    vio.write_volume(vol, str(tmp_path / "m.nii"))
    back = nib.load(str(tmp_path / "m.nii"))
    np.testing.assert_array_equal(np.asanyarray(back.dataobj), xyz)
    np.testing.assert_allclose(back.header.get_zooms(), (0.5, 0.75, 2.5))


def test_nifti_scl_slope_keeps_integers(tmp_path):
    nib = pytest.importorskip("nibabel")
    xyz = _ramp(np.int16).transpose(2, 1, 0).copy()
    img = nib.Nifti1Image(xyz, np.eye(4))
    img.header.set_data_dtype(np.int16)
    img.header.set_slope_inter(0.5, -10.0)
    img.to_filename(str(tmp_path / "s.nii.gz"))
    vol = vio.read_volume(str(tmp_path / "s.nii.gz"))
    assert vol.dtype == np.int16
    np.testing.assert_array_equal(vol.data, _ramp(np.int16))
    assert vol.meta["nifti_scl"] == [0.5, -10.0]
    assert vio.read_header(str(tmp_path / "s.nii.gz"))["dtype"] == "int16"
    # written back, the scaling survives and nibabel's scaled view agrees
    vio.write_volume(vol, str(tmp_path / "t.nii.gz"))
    again = nib.load(str(tmp_path / "t.nii.gz"))
    np.testing.assert_allclose(again.get_fdata(), xyz * 0.5 - 10.0)


@pytest.mark.parametrize(
    ("name", "fmt", "dtype", "scaled"),
    [
        ("test.mgz", "mgh", "float32", False),  # FreeSurfer MGZ
        ("minc1_1_scale.mnc", "minc", "float64", False),  # scaled per slice
        ("minc2-no-att.mnc", "minc", "float64", False),
        ("example4d+orig.HEAD", "afni", "int16", False),
        ("example4d+orig.BRIK.gz", "afni", "int16", False),
        ("phantom_EPI_asc_CLEAR_2_1.PAR", "parrec", "uint16", True),  # one slope for all
        ("phantom_varscale.REC", "parrec", "float64", False),  # a slope per slice
    ],
)
def test_other_nibabel_formats_read_as_nibabel_scales_them(name, fmt, dtype, scaled, tmp_path):
    """MGH/MGZ, MINC, AFNI and PAR/REC through the NIfTI reader: the stored integers where
    one (slope, intercept) maps them all (kept as nifti_scl), else the scaled float64
    values; either way the physical values equal nibabel's, in (t,) z, y, x order."""
    nib = pytest.importorskip("nibabel")
    path = str(Path(nib.__file__).parent / "tests" / "data" / name)
    img = nib.load(path)
    vol = vio.read_volume(path)
    assert vio.detect_format(path) == fmt and vol.meta["source_format"] == fmt
    assert vol.dtype == np.dtype(dtype) and ("nifti_scl" in vol.meta) == scaled
    assert vio.read_header(path)["dtype"] == dtype
    phys = vol.data.astype(np.float64)
    if scaled:
        slope, inter = vol.meta["nifti_scl"]
        phys = phys * slope + inter
    ref = np.asarray(img.dataobj, dtype=np.float64)
    opened = getattr(img.dataobj, "file_like", None)
    if hasattr(opened, "close"):  # nibabel's PAR/REC keeps its .REC open
        opened.close()
    ref = ref.reshape(ref.shape[:4]).transpose(tuple(range(min(ref.ndim, 4) - 1, -1, -1)))
    np.testing.assert_array_equal(phys, ref.reshape(phys.shape))
    assert vol.spacing == tuple(float(z) for z in img.header.get_zooms()[:3][::-1])
    # out as NIfTI: the same physical values (NIfTI keeps its slope as float32)
    out = str(tmp_path / "o.nii.gz")
    vio.write_volume(vol, out)
    back = nib.load(out)
    want = ref.transpose(tuple(range(ref.ndim - 1, -1, -1))).reshape(back.shape)
    np.testing.assert_allclose(np.asarray(back.dataobj, dtype=np.float64), want, rtol=1e-6)


def test_nrrd_fortran_file_is_read_as_zyx(tmp_path):
    nrrd = pytest.importorskip("nrrd")
    a = _ramp(np.uint16)
    header = {"spacings": [0.5, 0.75, 2.5]}  # file order x, y, z
    nrrd.write(str(tmp_path / "f.nrrd"), a.transpose(2, 1, 0).copy(), header)  # index_order F
    vol = vio.read_volume(str(tmp_path / "f.nrrd"))
    np.testing.assert_array_equal(vol.data, a)
    assert vol.spacing == SPACING
    assert vio.read_header(str(tmp_path / "f.nrrd"))["spacing"] == list(SPACING)


def test_hdf5_dataset_choice_and_attrs(tmp_path):
    h5py = pytest.importorskip("h5py")
    path = str(tmp_path / "f.h5")
    a = _ramp(np.uint8)
    with h5py.File(path, "w") as f:
        f["one/vol"] = a
        f["one/vol"].attrs["element_size_um"] = SPACING
    vol = vio.read_volume(path)  # the only dataset
    np.testing.assert_array_equal(vol.data, a)
    assert vol.spacing == SPACING
    # writing another dataset with force keeps the first one
    vio.write_volume(a * 2, path + ":/two", force=True)
    np.testing.assert_array_equal(vio.read_volume(path + ":/one/vol").data, a)
    np.testing.assert_array_equal(vio.read_volume(path + ":two").data, a * 2)
    with pytest.raises(FormatError, match="expected one dataset"):
        vio.read_volume(path)
    with pytest.raises(FormatError, match="/nope"):
        vio.read_volume(path + ":/nope")


def test_parse_spec():
    assert vio.parse_spec("a/b.h5:/g/ds") == ("a/b.h5", "/g/ds")
    assert vio.parse_spec("b.HDF5:ds") == ("b.HDF5", "/ds")
    assert vio.parse_spec("b.nc") == ("b.nc", None)
    assert vio.parse_spec("c:/x.npy") == ("c:/x.npy", None)
    assert vio.parse_spec("-") == ("-", None)


def test_detect_format(tmp_path):
    cases = {
        "a.npy": "npy",
        "a.RAW": "raw",
        "a.bin": "raw",
        "a.img": "raw",
        "a.nii": "nifti",
        "a.nii.gz": "nifti",
        "a.hdr": "nifti",
        "a.mgz": "mgh",
        "a.MNC": "minc",
        "a+orig.HEAD": "afni",
        "a.PAR": "parrec",
        "a.nrrd": "nrrd",
        "a.nhdr": "nrrd",
        "a.hdf5": "hdf5",
        "a.h5:/x": "hdf5",
        "a.nc": "netcdf",
        "a.CDF:u": "netcdf",
        "a.tiff": "tiff",
        "a.den": "den",
        "a.vpk": "vpk",
        "-": "npy",
    }
    for name, fmt in cases.items():
        assert vio.detect_format(name) == fmt, name
    (tmp_path / "an.hdr").write_bytes(b"")
    assert vio.detect_format(str(tmp_path / "an.img")) == "nifti"  # Analyze pair
    with pytest.raises(FormatError, match=r"\.nii\.gz.*found 'volume\.xyz'"):
        vio.detect_format("volume.xyz")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(FormatError, match="folder"):
        vio.detect_format(str(empty))


def test_unknown_extension_errors(tmp_path):
    with pytest.raises(FormatError, match="extensions"):
        vio.read_volume(str(tmp_path / "v.xyz"))
    with pytest.raises(FormatError, match="output ending in"):
        vio.write_volume(_ramp(np.uint8), str(tmp_path / "v.xyz"))


def test_raw_errors(tmp_path):
    path = tmp_path / "v.raw"
    _ramp(np.int16).tofile(path)
    with pytest.raises(FormatError, match="expected 212 bytes for shape .* found 210"):
        vio.read_volume(str(path), shape=SHAPE, dtype="int16", offset=2)
    with pytest.raises(FormatError, match="found 210"):
        vio.read_volume(str(path), shape=(3, 5, 8), dtype="int16")
    with pytest.raises(FormatError, match="expected shape="):
        vio.read_volume(str(path), dtype="int16")
    with pytest.raises(FormatError, match="expected dtype="):
        vio.read_volume(str(path), shape=SHAPE)
    with pytest.raises(FormatError, match="at most 100 voxels"):
        vio.read_volume(str(path), shape=SHAPE, dtype="int16", max_voxels=100)
    with pytest.raises(FormatError, match="integer or float"):
        vio.read_volume(str(path), shape=(3, 5, 7), dtype="complex64")


def test_raw_offset_and_big_endian(tmp_path):
    a = _ramp(np.uint16)
    path = tmp_path / "be.bin"
    path.write_bytes(b"HEADER" + a.astype(">u2").tobytes())
    vol = vio.read_volume(str(path), shape=SHAPE, dtype="uint16", byteorder=">", offset=6)
    np.testing.assert_array_equal(vol.data, a)
    assert vol.dtype.isnative


def test_shape_and_dtype_read_any_file_as_raw(tmp_path):
    # an INRIMAGE, a GrADS .dat, a .npy: shape and dtype given means raw, whatever the name
    a = _ramp(np.int16)
    for name in ("v.inr", "v.dat", "v.npy"):
        path = tmp_path / name
        path.write_bytes(b"H" * 256 + a.astype("<i2").tobytes())
        vol = vio.read_volume(str(path), shape=SHAPE, dtype="int16", offset=256)
        np.testing.assert_array_equal(vol.data, a)
        assert vol.meta["source_format"] == "raw"
        assert vio.read_header(str(path), shape=SHAPE, dtype="int16", offset=256)["shape"] == list(
            SHAPE
        )
    with pytest.raises(FormatError, match=r"raw shape of 3 \(z, y, x\) or 4"):
        vio.read_volume(str(path), shape=(5, 7), dtype="int16", offset=256)


def test_offset_alone_rejected_for_non_raw(tmp_path):
    spec = str(tmp_path / "v.npy")
    vio.write_volume(_ramp(np.uint8), spec)
    with pytest.raises(FormatError, match="found only offset=16"):
        vio.read_volume(spec, offset=16)


def test_missing_and_corrupt_files(tmp_path):
    with pytest.raises(FormatError, match="found nothing"):
        vio.read_volume(str(tmp_path / "absent.nii.gz"))
    bad = tmp_path / "bad.nii.gz"
    bad.write_bytes(b"not a nifti file at all")
    with pytest.raises(FormatError, match="could not read nifti"):
        vio.read_volume(str(bad))
    bad = tmp_path / "bad.npy"
    bad.write_bytes(b"garbage")
    with pytest.raises(FormatError, match=r"\.npy header"):
        vio.read_volume(str(bad))
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"garbage")
    with pytest.raises(FormatError, match="could not read hdf5"):
        vio.read_volume(str(bad))


def test_unsupported_dtypes(tmp_path):
    spec = str(tmp_path / "c.npy")
    np.save(spec, np.zeros(SHAPE, np.complex64))
    with pytest.raises(FormatError, match="integer or float voxels"):
        vio.read_volume(spec)
    np.save(spec, np.ones(SHAPE, bool))
    vol = vio.read_volume(spec)  # bool stays bool (it used to come back as uint8)
    assert vol.dtype == bool


def test_refuse_overwrite(tmp_path):
    for name in ("v.npy", "v.nii.gz", "v.h5:/data", "v.tif", "v.raw"):
        spec = str(tmp_path / name)
        vio.write_volume(_ramp(np.uint8), spec)
        with pytest.raises(OutputExistsError, match="force"):
            vio.write_volume(_ramp(np.uint8) + 1, spec)
        vio.write_volume(_ramp(np.uint8) + 1, spec, force=True)
        kw = _raw_kw(name, np.uint8)
        np.testing.assert_array_equal(vio.read_volume(spec, **kw).data, _ramp(np.uint8) + 1)


@pytest.mark.parametrize("name", ["v.xyz", "slices/", "v.dcm", "v.npy/"])
def test_an_output_volpack_cannot_write_names_the_writable_extensions(tmp_path, name):
    from volpack import api

    spec = f"{tmp_path}/{name}"  # (a Path would drop the trailing slash)
    for write in (vio.write_volume, api.write_volume):
        with pytest.raises(FormatError, match=r"expected an output ending in .*\.nii\.gz") as e:
            write(_ramp(np.uint8), spec)
        assert "folder" not in str(e.value) and ".dcm," not in str(e.value)
    assert os.listdir(tmp_path) == []


def test_failed_write_leaves_nothing(tmp_path, monkeypatch):
    import tifffile

    def boom(*args, **kwargs):
        with open(args[0], "wb") as f:  # a partial file in the temporary place
            f.write(b"partial")
        raise RuntimeError("disk full")

    monkeypatch.setattr(tifffile, "imwrite", boom)
    with pytest.raises(FormatError, match="could not write tiff.*disk full"):
        vio.write_volume(_ramp(np.uint8), str(tmp_path / "v.tif"))
    assert os.listdir(tmp_path) == []

    # an existing file survives a failed replacement untouched
    target = tmp_path / "keep.npy"
    vio.write_volume(_ramp(np.uint8), str(target))

    def half_save(f, arr, **kwargs):
        f.write(b"\x93NUMPY partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(np, "save", half_save)
    with pytest.raises(FormatError, match="could not write npy.*No space left"):
        vio.write_volume(_ramp(np.int16), str(target), force=True)
    assert os.listdir(tmp_path) == ["keep.npy"]
    np.testing.assert_array_equal(np.load(target), _ramp(np.uint8))


def test_nan_mask_restored_on_write(tmp_path):
    from volpack.prep import mask_special

    a = _ramp(np.float32)
    a[1, 2, 3] = np.nan
    a[0, 0, 0] = np.inf
    vol = mask_special(Volume(a))
    spec = str(tmp_path / "m.npy")
    vio.write_volume(vol, spec)
    np.testing.assert_array_equal(np.load(spec), a)  # NaN == NaN in assert_array_equal


def _stdio(monkeypatch, data: bytes = b""):
    out = types.SimpleNamespace(buffer=io.BytesIO())
    monkeypatch.setattr(sys, "stdin", types.SimpleNamespace(buffer=io.BytesIO(data)))
    monkeypatch.setattr(sys, "stdout", out)
    return out.buffer


def test_stdin_stdout_npy(monkeypatch):
    a = _ramp(np.int16)
    out = _stdio(monkeypatch)
    vio.write_volume(a, "-")
    blob = out.getvalue()
    np.testing.assert_array_equal(np.load(io.BytesIO(blob)), a)
    _stdio(monkeypatch, blob)
    vol = vio.read_volume("-")
    np.testing.assert_array_equal(vol.data, a)
    _stdio(monkeypatch, blob)
    assert vio.read_header("-")["shape"] == list(SHAPE)
    _stdio(monkeypatch, b"hello")
    with pytest.raises(FormatError, match="npy stream"):
        vio.read_volume("-")
    _stdio(monkeypatch, a.tobytes())  # raw on stdin when shape and dtype are given
    np.testing.assert_array_equal(vio.read_volume("-", shape=SHAPE, dtype="int16").data, a)


def test_stdout_in_a_real_pipe(tmp_path):
    code = (
        "import numpy as np; from volpack import io;"
        "io.write_volume(np.arange(105, dtype=np.uint16).reshape(3, 5, 7), '-')"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, check=True)
    np.testing.assert_array_equal(
        np.load(io.BytesIO(res.stdout)), np.arange(105, dtype=np.uint16).reshape(SHAPE)
    )


def _den_bytes(a: np.ndarray) -> bytes:
    """A VolPack .den file made from the layout: 29 little-endian int16 then an int32."""
    nz, ny, nx = a.shape
    lens = [nx, ny, nz]
    shorts = [1]  # version
    for _ in range(3):  # original, extracted, map: min, max, len (x, y, z each)
        shorts += [0, 0, 0] + [n - 1 for n in lens] + lens
    shorts.append(0)  # warps
    head = np.array(shorts, "<i2").tobytes() + np.array([a.size], "<i4").tobytes()
    assert len(head) == 62
    return head + a.astype(np.uint8).tobytes()  # x fastest


def test_den_by_hand(tmp_path):
    a = _ramp(np.uint8)
    path = tmp_path / "tiny.den"
    path.write_bytes(_den_bytes(a))
    vol = vio.read_volume(str(path))
    np.testing.assert_array_equal(vol.data, a)
    assert vol.meta["source_format"] == "den"
    assert vio.read_header(str(path))["shape"] == list(SHAPE)
    # our writer makes the same bytes
    vio.write_volume(a, str(tmp_path / "ours.den"))
    assert (tmp_path / "ours.den").read_bytes() == path.read_bytes()
    # wrong sizes and limits
    (tmp_path / "short.den").write_bytes(_den_bytes(a)[:-1])
    with pytest.raises(FormatError, match="expected 167 bytes"):
        vio.read_volume(str(tmp_path / "short.den"))
    with pytest.raises(FormatError, match="at most 10 voxels"):
        vio.read_volume(str(path), max_voxels=10)
    (tmp_path / "v2.den").write_bytes(b"\x02\x00" + _den_bytes(a)[2:])
    with pytest.raises(FormatError, match="version 1"):
        vio.read_volume(str(tmp_path / "v2.den"))
    with pytest.raises(FormatError, match="uint8"):
        vio.write_volume(_ramp(np.int16), str(tmp_path / "i16.den"))


def test_tiff_folder(tmp_path):
    tifffile = pytest.importorskip("tifffile")
    a = _ramp(np.uint16, (12, 5, 7))
    folder = tmp_path / "stack"
    folder.mkdir()
    for i, sl in enumerate(a):  # natural order: slice_2 before slice_10
        tifffile.imwrite(folder / f"slice_{i}.tif", sl, resolution=(1 / 0.5, 1 / 0.75))
    (folder / "notes.txt").write_text("ignored")
    assert vio.detect_format(str(folder)) == "tiff-folder"
    vol = vio.read_volume(str(folder))
    np.testing.assert_array_equal(vol.data, a)
    np.testing.assert_allclose(vol.spacing, (1.0, 0.75, 0.5))
    assert vio.read_header(str(folder))["shape"] == [12, 5, 7]
    tifffile.imwrite(folder / "slice_99.tif", a[0, :4])
    with pytest.raises(FormatError, match="slice_99"):
        vio.read_volume(str(folder))


def test_png_slice_and_folder(tmp_path):
    from PIL import Image

    a = _ramp(np.uint16, (11, 5, 7)) * 97  # values past 255: a 16-bit PNG
    folder = tmp_path / "stack"
    folder.mkdir()
    for i, sl in enumerate(a):  # natural order: s2 before s10
        Image.fromarray(sl).save(folder / f"s{i}.png")
    (folder / "notes.txt").write_text("ignored")
    assert vio.detect_format(str(folder)) == "png-folder"
    vol = vio.read_volume(str(folder))
    assert vol.dtype == np.uint16 and vol.meta["slices"] == 11
    np.testing.assert_array_equal(vol.data, a)
    one = vio.read_volume(str(folder / "s3.png"))
    assert one.shape == (1, 5, 7)
    np.testing.assert_array_equal(one.data[0], a[3])
    assert vio.read_header(str(folder / "s3.png"))["shape"] == [1, 5, 7]
    grey = _ramp(np.uint8, (1, 5, 7))[0]
    Image.fromarray(grey).save(tmp_path / "g.png")
    np.testing.assert_array_equal(vio.read_volume(str(tmp_path / "g.png")).data[0], grey)
    Image.fromarray(grey > 20).save(tmp_path / "b.png")  # bilevel: 0/1 as uint8
    b = vio.read_volume(str(tmp_path / "b.png")).data
    assert b.dtype == np.uint8 and np.array_equal(b[0], (grey > 20).astype(np.uint8))
    with pytest.raises(FormatError, match="max_voxels|voxels"):
        vio.read_volume(str(folder), max_voxels=100)
    # what is refused, in one line naming the file
    Image.fromarray(np.stack([grey] * 3, axis=-1)).save(tmp_path / "rgb.png")
    with pytest.raises(FormatError, match="greyscale PNG.*found mode 'RGB'"):
        vio.read_volume(str(tmp_path / "rgb.png"))
    noise = np.random.default_rng(0).integers(0, 256, (64, 64), dtype=np.uint8)
    Image.fromarray(noise).save(tmp_path / "n.png")
    (tmp_path / "cut.png").write_bytes((tmp_path / "n.png").read_bytes()[:2000])
    with pytest.raises(FormatError, match="cut.png"):
        vio.read_volume(str(tmp_path / "cut.png"))
    (tmp_path / "fake.png").write_bytes(b"GIF89a" + bytes(40))
    with pytest.raises(FormatError, match="fake.png"):
        vio.read_volume(str(tmp_path / "fake.png"))
    Image.fromarray(a[0, :4]).save(folder / "s99.png")
    with pytest.raises(FormatError, match="s99"):
        vio.read_volume(str(folder))


def test_dicom_folder(tmp_path):
    need("pydicom", "dicom")
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian, generate_uid

    stored = _ramp(np.uint16, (4, 5, 7)) * 10
    folder = tmp_path / "series"
    folder.mkdir()
    order = [2, 0, 3, 1]  # files named out of order; positions decide
    for n, k in enumerate(order):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = FileDataset(str(folder / f"im{n}.dcm"), {}, file_meta=meta, preamble=b"\0" * 128)
        ds.Modality = "CT"
        ds.SOPClassUID = meta.MediaStorageSOPClassUID
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.Rows, ds.Columns = 5, 7
        ds.BitsAllocated, ds.BitsStored, ds.HighBit = 16, 16, 15
        ds.PixelRepresentation = 0
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.PixelSpacing = [0.75, 0.5]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.ImagePositionPatient = [3.5, 10.0, -4.0 + 2.5 * k]
        ds.InstanceNumber = n + 1
        ds.RescaleSlope = 1
        ds.RescaleIntercept = -1024
        ds.PixelData = stored[k].tobytes()
        ds.save_as(str(folder / f"im{n}.dcm"), enforce_file_format=True)
    assert vio.detect_format(str(folder)) == "dicom"
    vol = vio.read_volume(str(folder))
    expected = stored.astype(np.int32) - 1024
    np.testing.assert_array_equal(vol.data, expected)
    assert vol.dtype.kind == "i" and vol.dtype.itemsize <= 2
    np.testing.assert_allclose(vol.spacing, SPACING)
    np.testing.assert_allclose(vol.origin, ORIGIN)
    assert vol.meta["dicom_rescale"] == {"slope": 1.0, "intercept": -1024.0, "applied": True}
    assert vio.read_header(str(folder))["shape"] == [4, 5, 7]


def test_dicom_missing_says_how_to_install(tmp_path, monkeypatch):
    folder = tmp_path / "d"
    folder.mkdir()
    (folder / "x.dcm").write_bytes(b"\0" * 132)
    monkeypatch.setitem(sys.modules, "pydicom", None)  # import pydicom -> ImportError
    with pytest.raises(FormatError, match=r"pip install 'volpack\[dicom\]'"):
        vio.read_volume(str(folder))


def test_import_is_light():
    code = (
        "import sys, volpack.io;"
        "heavy = {'nibabel', 'h5py', 'tifffile', 'nrrd', 'pydicom'} & set(sys.modules);"
        "print(sorted(heavy))"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert res.stdout.strip() == "[]"


def test_a_2d_image_is_not_a_volume(tmp_path):
    p = tmp_path / "img.npy"
    np.save(p, np.zeros((5, 7), np.uint8))
    with pytest.raises(FormatError, match=r"3-D .* found shape \(5, 7\)"):
        vio.read_volume(str(p))


def test_npy_and_raw_are_memory_mapped(tmp_path):
    a = np.arange(3 * 4 * 5, dtype=np.int16).reshape(3, 4, 5)
    np.save(tmp_path / "a.npy", a)
    a.tofile(tmp_path / "a.raw")
    for vol in (
        vio.read_volume(str(tmp_path / "a.npy")),
        vio.read_volume(str(tmp_path / "a.raw"), shape=(3, 4, 5), dtype="int16"),
    ):
        assert isinstance(vol.data, np.memmap) or isinstance(vol.data.base, np.memmap)
        np.testing.assert_array_equal(vol.data, a)


# -- MetaImage, VTK image data, INRIMAGE: variants our writers do not produce -----------


def _vti_text(a, fmt: str, compressed: bool, header="UInt32", block=64) -> bytes:
    """A .vti written the way VTK does, built here independently of volpack's writer."""
    import base64
    import zlib

    hdt = "<u4" if header == "UInt32" else "<u8"
    raw = a.astype("<i2").tobytes()
    if compressed:
        blocks = [raw[i : i + block] for i in range(0, len(raw), block)]
        packed = [zlib.compress(b) for b in blocks]
        head = np.asarray([len(blocks), block, len(blocks[-1]), *map(len, packed)], hdt).tobytes()
        body = b"".join(packed)
        enc = base64.b64encode(head) + base64.b64encode(body)
        rawbin = head + body
    else:
        head = np.asarray([len(raw)], hdt).tobytes()
        enc = base64.b64encode(head + raw)
        rawbin = head + raw
    nz, ny, nx = a.shape
    comp = ' compressor="vtkZLibDataCompressor"' if compressed else ""
    arr = {
        "ascii": f'format="ascii">{" ".join(map(str, a.ravel()))}</DataArray>',
        "binary": f'format="binary">{enc.decode()}</DataArray>',
        "appended": 'format="appended" offset="0"/>',
    }[fmt]
    text = (
        f'<?xml version="1.0"?>\n<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
        f'header_type="{header}"{comp}>\n<ImageData WholeExtent="2 {nx + 1} 0 {ny - 1} 0 {nz - 1}" '
        f'Origin="1 2 3" Spacing="0.5 0.75 2.5">\n<Piece Extent="2 {nx + 1} 0 {ny - 1} 0 {nz - 1}">\n'
        f'<PointData Scalars="density"><DataArray type="Float32" Name="other" format="ascii">'
        f"{' '.join(['0'] * a.size)}</DataArray>\n"
        f'<DataArray type="Int16" Name="density" {arr}\n</PointData></Piece></ImageData>\n'
    ).encode()
    if fmt == "appended":
        text += b'<AppendedData encoding="raw">_' + rawbin + b"</AppendedData>\n"
    return text + b"</VTKFile>\n"


@pytest.mark.parametrize(
    ("fmt", "compressed", "header"),
    [
        ("ascii", False, "UInt32"),
        ("binary", False, "UInt32"),
        ("binary", True, "UInt32"),
        ("binary", True, "UInt64"),
        ("appended", False, "UInt64"),
        ("appended", True, "UInt32"),
    ],
)
def test_vti_variants(tmp_path, fmt, compressed, header):
    a = _ramp(np.int16)
    path = tmp_path / "v.vti"
    path.write_bytes(_vti_text(a, fmt, compressed, header))
    vol = vio.read_volume(str(path))
    np.testing.assert_array_equal(vol.data, a)
    assert vol.spacing == (2.5, 0.75, 0.5)
    assert vol.origin == (3.0, 2.0, 1.0 + 2 * 0.5)  # extent starting at x=2 moves the origin
    assert vol.meta["vti_array"] == "density" and vol.meta["vti_arrays"] == ["other"]
    assert vio.read_header(str(path))["dtype"] == "int16"


def test_metaimage_compressed_big_endian_and_detached(tmp_path):
    import zlib

    a = _ramp(np.uint16)
    head = (
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = True\n"
        "CompressedData = True\nElementSpacing = 0.5 0.75 2.5\nOffset = 1 2 3\n"
        f"DimSize = {SHAPE[2]} {SHAPE[1]} {SHAPE[0]}\nElementType = MET_USHORT\n"
    )
    (tmp_path / "c.mha").write_bytes(
        (head + "ElementDataFile = LOCAL\n").encode() + zlib.compress(a.astype(">u2").tobytes())
    )
    vol = vio.read_volume(str(tmp_path / "c.mha"))
    np.testing.assert_array_equal(vol.data, a)
    assert vol.spacing == (2.5, 0.75, 0.5) and vol.origin == (3.0, 2.0, 1.0)
    # a detached header whose data file has a header of its own (HeaderSize = -1: at the end)
    head = head.replace("CompressedData = True", "CompressedData = False")
    (tmp_path / "d.mhd").write_text(head + "HeaderSize = -1\nElementDataFile = d.dat\n")
    (tmp_path / "d.dat").write_bytes(b"junk" * 10 + a.astype(">u2").tobytes())
    np.testing.assert_array_equal(vio.read_volume(str(tmp_path / "d.mhd")).data, a)
    (tmp_path / "e.mhd").write_text(head + "ElementDataFile = LIST\n")
    with pytest.raises(FormatError, match="LOCAL or one file"):
        vio.read_volume(str(tmp_path / "e.mhd"))


def test_inr_header_checks(tmp_path):
    path = tmp_path / "v.inr"
    text = "#INRIMAGE-4#{\nXDIM=7\nYDIM=5\nZDIM=3\nVDIM=3\nTYPE=float\nPIXSIZE=32 bits\nCPU=sun\n"
    path.write_bytes(text.encode() + b"\n" * (252 - len(text)) + b"##}\n" + bytes(105 * 12))
    with pytest.raises(FormatError, match="VDIM=1"):
        vio.read_volume(str(path))
    path.write_bytes(path.read_bytes().replace(b"VDIM=3", b"VDIM=1"))
    with pytest.raises(FormatError, match="expected 420 bytes .*, found more"):
        vio.read_volume(str(path))
    path.write_bytes(path.read_bytes()[: 256 + 400])
    with pytest.raises(FormatError, match="expected 420 bytes .*, found 400"):
        vio.read_volume(str(path))


_DATA = os.path.expanduser(os.environ.get("VOLPACK_DATA", "~/.cache/volpack/data"))


def _cached(name: str) -> str:
    path = os.path.join(_DATA, name)
    if not os.path.exists(path):
        pytest.skip(f"{name} is not cached (python scripts/fetch_data.py fetches it)")
    return path


def test_real_inrimage_liver():
    import gzip

    path = _cached("liver.inr.gz")
    blob = gzip.open(path).read()
    vol = vio.read_volume(path)
    assert vol.shape == (165, 353, 438) and vol.dtype == np.uint8
    np.testing.assert_array_equal(vol.data.ravel(), np.frombuffer(blob[256:], np.uint8))
    assert vol.spacing == pytest.approx((1.33333, 0.617188, 0.617188))
    assert set(np.unique(vol.data)) == {0, 84, 85, 127, 255}


def test_real_vti_heart_ascii():
    import re

    path = _cached("heart.vti")
    text = Path(path).read_text()
    values = re.search(r'format="ascii">(.*?)</DataArray>', text, re.S).group(1).split()
    vol = vio.read_volume(path)
    assert vol.shape == (12, 32, 32) and vol.spacing == (4.0, 1.0, 1.0)
    np.testing.assert_array_equal(vol.data.ravel(), np.asarray(values, np.float32))
