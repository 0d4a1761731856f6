"""External volume formats in and out: npy, raw, NIfTI/Analyze, NRRD, HDF5, TIFF,
VolPack ``.den``, DICOM folders and ``.vpk``; ``'-'`` is a ``.npy`` stream on stdin/stdout.

Every reader returns a :class:`~volpack.volume.Volume` in ``(z, y, x)`` order (time
leading, ``(t, z, y, x)``), C-contiguous and in native byte order, with provenance in
``meta['source_format']`` and friends. Every failure is a :class:`FormatError` whose
message says what was expected and what was found.

The heavy libraries (nibabel, h5py, tifffile, pynrrd, pydicom) are imported inside the
functions that need them, never at module import, so ``volpack --help`` stays fast.
"""

from __future__ import annotations

import contextlib
import io as _io
import json
import math
import os
import re
import shutil
import sys
from collections.abc import Iterator
from typing import Any

import numpy as np

from ..errors import FormatError
from ..format.streams import stdin
from ..jsonsafe import jsonable
from ..volume import Volume

__all__ = ["parse_spec", "detect_format", "read_volume", "write_volume", "read_header"]

DEFAULT_MAX_VOXELS = 1 << 34
DEFAULT_H5_DATASET = "/data"

_HDF5_EXTS = (".h5", ".hdf5", ".hdf", ".nc")
# suffix -> format; longest suffixes are tried first
_EXTENSIONS = {
    ".npy": "npy",
    ".raw": "raw",
    ".bin": "raw",
    ".img": "raw",  # becomes "nifti" when a sibling .hdr exists (Analyze 7.5)
    ".nii": "nifti",
    ".nii.gz": "nifti",
    ".hdr": "nifti",
    ".nrrd": "nrrd",
    ".nhdr": "nrrd",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
    ".nc": "hdf5",
    ".tif": "tiff",
    ".tiff": "tiff",
    ".den": "den",
    ".dcm": "dicom",
    ".vpk": "vpk",
}
_TIFF_EXTS = (".tif", ".tiff")

# VolPack .den: 29 int16 (version, orig/extr/map min/max/len triples, warps) + int32 count
_DEN_HEADER = 62
_DEN_VERSION = 1


# -- specs and formats -------------------------------------------------------------


def parse_spec(spec: str) -> tuple[str, str | None]:
    """Split ``"file.h5:/group/ds"`` into ``("file.h5", "/group/ds")``.

    Only a part before ``:`` that ends in an HDF5 extension (.h5, .hdf5, .hdf, .nc) is
    split off; any other spec, and ``'-'``, comes back as ``(spec, None)``.
    """
    spec = os.fspath(spec)
    if spec == "-":
        return "-", None
    low = spec.lower()
    for ext in _HDF5_EXTS:
        i = low.find(ext + ":")
        if i >= 0:
            path, inner = spec[: i + len(ext)], spec[i + len(ext) + 1 :]
            if not inner:
                return path, None
            return path, inner if inner.startswith("/") else "/" + inner
    return spec, None


def detect_format(path: str) -> str:
    """Name the format of ``path`` from its extension (folders: from their content).

    Returns one of ``npy, raw, nifti, nrrd, hdf5, tiff, tiff-folder, den, dicom, vpk``.
    """
    path, _ = parse_spec(os.fspath(path))
    if path == "-":
        return "npy"
    if os.path.isdir(path):
        return _detect_folder(path)
    low = path.lower()
    for ext in sorted(_EXTENSIONS, key=len, reverse=True):
        if low.endswith(ext):
            fmt = _EXTENSIONS[ext]
            if ext == ".img" and os.path.exists(path[:-4] + ".hdr"):
                return "nifti"
            return fmt
    known = ", ".join(sorted(_EXTENSIONS))
    raise FormatError(
        f"expected a volume file with one of the extensions {known}, a folder of TIFF or "
        f"DICOM slices, or '-', found {path!r}"
    )


def _detect_folder(path: str) -> str:
    names = [n for n in sorted(os.listdir(path)) if not n.startswith(".")]
    if any(n.lower().endswith(_TIFF_EXTS) for n in names):
        return "tiff-folder"
    for n in names:
        if n.lower().endswith(".dcm") or _has_dicom_magic(os.path.join(path, n)):
            return "dicom"
    raise FormatError(f"expected a folder of .tif/.tiff or DICOM slices, found none in {path!r}")


def _has_dicom_magic(path: str) -> bool:
    try:
        with open(path, "rb") as f:
            f.seek(128)
            return f.read(4) == b"DICM"
    except OSError:
        return False


# -- public entry points -----------------------------------------------------------


def read_volume(
    spec: str,
    *,
    shape: tuple[int, ...] | None = None,
    dtype: Any = None,
    byteorder: str = "<",
    offset: int = 0,
    max_voxels: int = DEFAULT_MAX_VOXELS,
) -> Volume:
    """Read a volume from a file, folder, ``file.h5:/dataset`` or ``'-'`` (stdin).

    Parameters
    ----------
    spec : str
        Path or spec; the format comes from :func:`detect_format`.
    shape, dtype, byteorder, offset
        Raw input only (``.raw``/``.bin``/``.img``, or ``'-'`` when shape and dtype are
        given): ``(z, y, x)`` or ``(t, z, y, x)`` shape, voxel type, ``'<'``/``'>'``
        byte order and the number of header bytes to skip.
    max_voxels : int
        Refuse volumes whose declared size exceeds this before allocating.
    """
    path, inner = parse_spec(spec)
    raw_given = shape is not None or dtype is not None
    if path == "-":
        if raw_given:
            blob = stdin().read()
            return _raw_from_bytes(blob, "<stdin>", shape, dtype, byteorder, offset, max_voxels)
        return _read_stdin_npy(max_voxels)
    fmt = detect_format(path)
    if fmt != "raw" and (raw_given or offset):
        raise FormatError(
            f"expected --shape/--dtype/--offset only for raw input, found them for the "
            f"{fmt} file {path!r}"
        )
    if not os.path.exists(path):
        raise FormatError(f"expected an existing {fmt} file, found nothing at {path!r}")
    if fmt == "vpk":  # decoding needs the stream kinds, a layer above this one
        raise FormatError(
            f"expected a volume file, found the .vpk {path!r}: read it with "
            "volpack.read_volume or volpack.decompress"
        )
    reader = _READERS[fmt]
    with _wrap(fmt, path):
        if fmt == "raw":
            vol = reader(path, shape, dtype, byteorder, offset, max_voxels)
        elif fmt == "hdf5":
            vol = reader(path, inner, max_voxels)
        else:
            vol = reader(path, max_voxels)
    return vol


def read_header(spec: str, **raw_options: Any) -> dict[str, Any]:
    """Return ``format``, ``shape``, ``dtype``, ``spacing`` and ``origin`` of a volume,
    reading only its header where the format allows (npy, raw, den, NIfTI, NRRD, HDF5,
    TIFF); DICOM folders, ``.vpk`` and stdin are read whole.

    ``dtype`` is the type :func:`read_volume` returns (native byte order).
    """
    path, inner = parse_spec(spec)
    max_voxels = raw_options.get("max_voxels", DEFAULT_MAX_VOXELS)
    fmt = "npy" if path == "-" else detect_format(path)
    if fmt == "vpk":
        from ..format.container import Reader

        with Reader(path) as r:
            h = r.header
        try:
            dtype = np.dtype(h["dtype"]).newbyteorder("=")
            return _header_dict(fmt, tuple(h["shape"]), dtype, h["spacing"], h["origin"], {})
        except (KeyError, TypeError, ValueError) as e:
            raise FormatError(f"expected a volume header in {path!r}, found {e!r}") from None
    if path == "-" or fmt in ("dicom", "tiff-folder"):
        vol = read_volume(spec, **raw_options)
        return _header_dict(fmt, vol.shape, vol.dtype, vol.spacing, vol.origin, vol.meta)
    if fmt != "raw" and any(raw_options.get(k) for k in ("shape", "dtype", "offset")):
        raise FormatError(
            f"expected --shape/--dtype/--offset only for raw input, found them for the "
            f"{fmt} file {path!r}"
        )
    if not os.path.isfile(path):
        raise FormatError(f"expected an existing {fmt} file, found nothing at {path!r}")
    with _wrap(fmt, path):
        if fmt == "raw":
            return _raw_header(
                path,
                raw_options.get("shape"),
                raw_options.get("dtype"),
                raw_options.get("byteorder", "<"),
                raw_options.get("offset", 0),
                max_voxels,
            )
        if fmt == "hdf5":
            return _hdf5_header(path, inner)
        return _HEADERS[fmt](path)


def write_volume(vol: Volume | np.ndarray, spec: str, *, force: bool = False) -> None:
    """Write a volume to ``spec``: ``.npy``, ``.raw``/``.bin``, ``.nii``/``.nii.gz``,
    ``.nrrd``, ``file.h5[:/dataset]`` (default ``/data``), ``.tif``/``.tiff``
    (multi-page), ``.den`` (uint8 only), ``.vpk`` or ``'-'`` (``.npy`` to stdout).

    Files are written atomically (temporary file beside the target, then rename); an
    existing file is replaced only with ``force``. Masked float voxels are put back to
    their recorded NaN/Inf values first; a mask on integer data is not written.
    """
    if not isinstance(vol, Volume):
        vol = Volume(np.asarray(vol))
    vol = _prepare_for_write(vol)
    path, inner = parse_spec(spec)
    if path == "-":
        buf = _io.BytesIO()
        np.save(buf, vol.data, allow_pickle=False)
        out = sys.stdout.buffer
        out.write(buf.getvalue())
        out.flush()
        return
    fmt = detect_format(path)
    if fmt == "hdf5":
        _write_hdf5(vol, path, inner or DEFAULT_H5_DATASET, force)
        return
    if fmt == "vpk":
        raise FormatError(
            f"expected a volume file to write, found the .vpk {path!r}: write it with "
            "volpack.write_volume or volpack.compress"
        )
    writer = _WRITERS.get(fmt)
    if writer is None or (fmt == "nifti" and not path.lower().endswith((".nii", ".nii.gz"))):
        raise FormatError(
            f"expected an output ending in .npy, .raw, .bin, .nii, .nii.gz, .nrrd, .h5, "
            f".hdf5, .tif, .tiff, .den or .vpk, found {path!r} ({fmt} is read-only)"
        )
    if fmt == "nrrd" and path.lower().endswith(".nhdr"):
        raise FormatError(
            f"expected an .nrrd output (detached .nhdr headers are read-only), found {path!r}"
        )
    if vol.dtype.kind == "b" and fmt != "npy":  # .npy, .h5 and .vpk keep bool; others have none
        vol = vol.replace(data=vol.data.astype(np.uint8))
    with _wrap(fmt, path, writing=True):
        writer(vol, path, force)


# -- shared helpers ------------------------------------------------------------------


@contextlib.contextmanager
def _wrap(fmt: str, path: str, writing: bool = False) -> Iterator[None]:
    """Turn library exceptions into one-line FormatErrors (ours pass through)."""
    try:
        yield
    except FormatError:
        raise
    except FileExistsError:
        raise
    except MemoryError:
        raise
    except Exception as e:  # every library failure becomes a FormatError
        what = "write" if writing else "read"
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise FormatError(f"could not {what} {fmt} file {path!r}: {msg}") from e


def _check_voxels(shape: tuple[int, ...], max_voxels: int, where: str) -> None:
    n = math.prod(int(s) for s in shape)
    if n > max_voxels:
        raise FormatError(
            f"expected at most {max_voxels} voxels, found shape {tuple(shape)} "
            f"({n} voxels) in {where}; raise max_voxels to read it"
        )


def _as_volume_array(arr: np.ndarray, meta: dict, where: str) -> np.ndarray:
    """Make ``arr`` 3-D or 4-D, native byte order, C-contiguous and of a supported type."""
    arr = np.asarray(arr)
    if arr.dtype.kind not in "biuf":  # bool stays bool: the codecs store it as it is
        raise FormatError(f"expected integer or float voxels in {where}, found dtype {arr.dtype}")
    while arr.ndim > 4 and arr.shape[-1] == 1:
        arr = arr[..., 0]
    if arr.ndim not in (3, 4):
        raise FormatError(
            f"expected a 3-D (z, y, x) or 4-D (t, z, y, x) volume in {where}, "
            f"found shape {arr.shape}"
        )
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    return np.ascontiguousarray(arr)


def _spacing3(values, default: float = 1.0) -> tuple[float, float, float]:
    """Three positive finite numbers, anything else replaced by ``default``."""
    out = []
    for v in list(values)[:3]:
        try:
            f = float(v)
        except (TypeError, ValueError):
            f = default
        out.append(f if math.isfinite(f) and f > 0 else default)
    while len(out) < 3:
        out.insert(0, default)
    return tuple(out)  # type: ignore[return-value]


def _origin3(values) -> tuple[float, float, float]:
    out = []
    for v in list(values)[:3]:
        try:
            f = float(v)
        except (TypeError, ValueError):
            f = 0.0
        out.append(f if math.isfinite(f) else 0.0)
    while len(out) < 3:
        out.insert(0, 0.0)
    return tuple(out)  # type: ignore[return-value]


def _header_dict(fmt, shape, dtype, spacing, origin, meta=None) -> dict[str, Any]:
    d: dict[str, Any] = {
        "format": fmt,
        "shape": [int(s) for s in shape],
        "dtype": str(np.dtype(dtype).newbyteorder("=")),
        "spacing": [float(s) for s in spacing],
        "origin": [float(o) for o in origin],
    }
    if meta:
        d["meta"] = jsonable(meta)
    return d


def _native(dtype: Any) -> np.dtype:
    return np.dtype(dtype).newbyteorder("=")


def _prepare_for_write(vol: Volume) -> Volume:
    if vol.mask is not None and vol.dtype.kind == "f" and "special" in vol.meta:
        from ..prep import unmask_special

        vol = unmask_special(vol)
    if not vol.data.dtype.isnative or not vol.data.flags.c_contiguous:
        vol = vol.replace(data=np.ascontiguousarray(vol.data, dtype=_native(vol.dtype)))
    return vol


def _refuse_float16(vol: Volume, fmt: str) -> None:
    if vol.dtype == np.float16:
        raise FormatError(
            f"expected a dtype {fmt} stores (8-64 bit integers, float32, float64), found "
            f"float16; convert it first (e.g. volpack convert --astype float32)"
        )


def _meta_json(vol: Volume) -> str | None:
    if not vol.meta:
        return None
    return json.dumps(jsonable(vol.meta), sort_keys=True)


def _meta_from_json(text: Any) -> dict:
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    try:
        m = json.loads(text)
    except (TypeError, ValueError):
        return {}
    return m if isinstance(m, dict) else {}


# -- npy and stdin -----------------------------------------------------------------


def _read_npy(path: str, max_voxels: int) -> Volume:
    hdr = _npy_header(path)
    _check_voxels(hdr["shape"], max_voxels, path)
    # Memory-mapped: a large volume is paged in brick by brick as it is coded.
    arr = np.load(path, allow_pickle=False, mmap_mode="r")
    meta: dict[str, Any] = {"source_format": "npy"}
    return Volume(_as_volume_array(arr, meta, path), meta=meta)


def _npy_header(path: str) -> dict[str, Any]:
    with open(path, "rb") as f:
        shape, dtype = _npy_shape_dtype(f, path)
    return _header_dict("npy", shape, _native(dtype), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def _npy_shape_dtype(f, where: str) -> tuple[tuple[int, ...], np.dtype]:
    fmt = np.lib.format
    try:
        version = fmt.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(f)
        else:
            shape, _, dtype = fmt.read_array_header_2_0(f)
    except ValueError as e:
        raise FormatError(f"expected a .npy header in {where}, found: {e}") from None
    return tuple(shape), dtype


def _read_stdin_npy(max_voxels: int) -> Volume:
    blob = stdin().read()
    if not blob.startswith(b"\x93NUMPY"):
        raise FormatError(
            f"expected a .npy stream on standard input, found {len(blob)} bytes starting "
            f"{blob[:8]!r}"
        )
    buf = _io.BytesIO(blob)
    shape, _ = _npy_shape_dtype(buf, "<stdin>")
    _check_voxels(shape, max_voxels, "<stdin>")
    buf.seek(0)
    try:
        arr = np.load(buf, allow_pickle=False)
    except ValueError as e:
        raise FormatError(f"could not read the .npy stream on standard input: {e}") from None
    meta: dict[str, Any] = {"source_format": "npy"}
    return Volume(_as_volume_array(arr, meta, "<stdin>"), meta=meta)


def _write_npy(vol: Volume, path: str, force: bool) -> None:
    from ..format.atomic import atomic_open

    with atomic_open(path, force=force) as f:
        np.save(f, vol.data, allow_pickle=False)


# -- raw -----------------------------------------------------------------------------


def _raw_dtype(dtype: Any, byteorder: str) -> np.dtype:
    if dtype is None:
        raise FormatError("expected --dtype (dtype=) for raw input, found none")
    order = {"little": "<", "big": ">", "native": "=", "<": "<", ">": ">", "=": "="}.get(
        str(byteorder)
    )
    if order is None:
        raise FormatError(f"expected byteorder '<' or '>', found {byteorder!r}")
    try:
        dt = np.dtype(dtype)
    except TypeError:
        raise FormatError(f"expected a numpy dtype such as uint16, found {dtype!r}") from None
    if dt.kind not in "iufb" or dt.fields is not None or dt.subdtype is not None:
        raise FormatError(f"expected an integer or float raw dtype, found {dt}")
    explicit = isinstance(dtype, str) and dtype[:1] in "<>|="
    return dt if explicit else dt.newbyteorder(order)


def _raw_shape(shape) -> tuple[int, ...]:
    if shape is None:
        raise FormatError("expected --shape (shape=) Z,Y,X for raw input, found none")
    try:
        sh = tuple(int(s) for s in shape)
    except (TypeError, ValueError):
        raise FormatError(f"expected a raw shape of integers, found {shape!r}") from None
    if len(sh) not in (3, 4) or min(sh) <= 0:
        raise FormatError(
            f"expected a raw shape of 3 (z, y, x) or 4 (t, z, y, x) positive integers, "
            f"found {shape!r}"
        )
    return sh


def _raw_check(shape, dtype, byteorder, offset, max_voxels, size: int, where: str):
    sh = _raw_shape(shape)
    dt = _raw_dtype(dtype, byteorder)
    if int(offset) < 0:
        raise FormatError(f"expected a non-negative offset, found {offset}")
    _check_voxels(sh, max_voxels, where)
    expected = int(offset) + math.prod(sh) * dt.itemsize
    if size != expected:
        raise FormatError(
            f"expected {expected} bytes for shape {sh} of {dt} at offset {offset} in "
            f"{where}, found {size}"
        )
    return sh, dt


def _read_raw(path, shape, dtype, byteorder, offset, max_voxels) -> Volume:
    sh, dt = _raw_check(shape, dtype, byteorder, offset, max_voxels, os.path.getsize(path), path)
    if dt.isnative:  # memory-mapped, as for .npy
        arr = np.memmap(path, dtype=dt, mode="r", offset=int(offset), shape=sh)
    else:
        arr = np.fromfile(path, dtype=dt, count=math.prod(sh), offset=int(offset)).reshape(sh)
    meta: dict[str, Any] = {"source_format": "raw"}
    return Volume(_as_volume_array(arr, meta, path), meta=meta)


def _raw_from_bytes(blob, where, shape, dtype, byteorder, offset, max_voxels) -> Volume:
    sh, dt = _raw_check(shape, dtype, byteorder, offset, max_voxels, len(blob), where)
    arr = np.frombuffer(blob, dtype=dt, count=math.prod(sh), offset=int(offset)).reshape(sh)
    meta: dict[str, Any] = {"source_format": "raw"}
    return Volume(_as_volume_array(arr.copy(), meta, where), meta=meta)


def _raw_header(path, shape, dtype, byteorder, offset, max_voxels) -> dict[str, Any]:
    sh, dt = _raw_check(shape, dtype, byteorder, offset, max_voxels, os.path.getsize(path), path)
    return _header_dict("raw", sh, _native(dt), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def _write_raw(vol: Volume, path: str, force: bool) -> None:
    from ..format.atomic import atomic_open

    data = vol.data.astype(vol.dtype.newbyteorder("<"), copy=False)
    with atomic_open(path, force=force) as f:
        f.write(memoryview(np.ascontiguousarray(data)).cast("B"))


# -- VolPack .den ----------------------------------------------------------------------


def _den_parse(head: bytes, size: int, path: str) -> dict[str, Any]:
    if len(head) < _DEN_HEADER:
        raise FormatError(
            f"expected a {_DEN_HEADER}-byte VolPack .den header in {path!r}, found {len(head)} bytes"
        )
    for order in "<>":
        shorts = np.frombuffer(head[:58], dtype=order + "i2")
        if int(shorts[0]) == _DEN_VERSION:
            break
    else:
        v = int(np.frombuffer(head[:2], "<i2")[0])
        raise FormatError(f"expected .den version {_DEN_VERSION} in {path!r}, found {v}")
    length = int(np.frombuffer(head[58:62], dtype=order + "i4")[0])
    nx, ny, nz = (int(v) for v in shorts[25:28])
    if min(nx, ny, nz) <= 0 or nx * ny * nz != length:
        raise FormatError(
            f"expected positive .den map lengths whose product is the voxel count {length} "
            f"in {path!r}, found {nx} x {ny} x {nz}"
        )
    if size != _DEN_HEADER + length:
        raise FormatError(
            f"expected {_DEN_HEADER + length} bytes for a .den map of {nx} x {ny} x {nz} "
            f"uint8 voxels in {path!r}, found {size}"
        )
    return {
        "shape": (nz, ny, nx),
        "byteorder": order,
        "orig_len": [int(v) for v in shorts[7:10]],
        "extr_min": [int(v) for v in shorts[10:13]],
        "extr_max": [int(v) for v in shorts[13:16]],
        "warps": int(shorts[28]),
    }


def _read_den(path: str, max_voxels: int) -> Volume:
    with open(path, "rb") as f:
        head = f.read(_DEN_HEADER)
        h = _den_parse(head, os.fstat(f.fileno()).st_size, path)
        _check_voxels(h["shape"], max_voxels, path)
        arr = np.fromfile(f, dtype=np.uint8, count=math.prod(h["shape"])).reshape(h["shape"])
    meta = {
        "source_format": "den",
        "den": {k: h[k] for k in ("orig_len", "extr_min", "extr_max", "warps", "byteorder")},
    }
    return Volume(np.ascontiguousarray(arr), meta=meta)


def _den_header(path: str) -> dict[str, Any]:
    with open(path, "rb") as f:
        h = _den_parse(f.read(_DEN_HEADER), os.fstat(f.fileno()).st_size, path)
    return _header_dict("den", h["shape"], np.uint8, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def _write_den(vol: Volume, path: str, force: bool) -> None:
    from ..format.atomic import atomic_open

    if vol.dtype != np.uint8 or vol.data.ndim != 3:
        raise FormatError(
            f"expected a 3-D uint8 volume for a .den file, found {vol.data.ndim}-D {vol.dtype}"
        )
    nz, ny, nx = vol.shape
    if max(vol.shape) > 32767:
        raise FormatError(f"expected .den axes of at most 32767 voxels, found {vol.shape}")
    lens = [nx, ny, nz]
    shorts = (
        [_DEN_VERSION]
        + [0, 0, 0]
        + [n - 1 for n in lens]
        + lens  # original
        + [0, 0, 0]
        + [n - 1 for n in lens]
        + lens  # extracted
        + [0, 0, 0]
        + [n - 1 for n in lens]
        + lens  # map
        + [0]  # warps
    )
    head = np.asarray(shorts, "<i2").tobytes() + np.asarray([nx * ny * nz], "<i4").tobytes()
    with atomic_open(path, force=force) as f:
        f.write(head)
        f.write(memoryview(vol.data).cast("B"))


# -- NIfTI / Analyze -------------------------------------------------------------------


_NIFTI_COMMENT = 6  # NIFTI_ECODE_COMMENT: carries volpack's meta as JSON


def _xyz_to_zyx(arr: np.ndarray) -> np.ndarray:
    """nibabel (x, y, z[, t]) -> (z, y, x) / (t, z, y, x)."""
    if arr.ndim <= 4:
        return arr.transpose(tuple(range(arr.ndim - 1, -1, -1)))
    return arr


def _nifti_load(path: str):
    import nibabel as nib

    return nib.load(path)


def _nifti_shape(img) -> tuple[int, ...]:
    shape = tuple(int(s) for s in img.shape)
    while len(shape) > 3 and shape[-1] == 1:
        shape = shape[:-1]
    if len(shape) > 4:
        raise FormatError(
            f"expected a 3-D or 4-D NIfTI image, found shape {shape} (x, y, z, t, ...)"
        )
    if len(shape) < 3:
        shape = shape + (1,) * (3 - len(shape))
    return shape[:3][::-1] if len(shape) == 3 else (shape[3], *shape[:3][::-1])


def _nifti_geometry(img) -> tuple[tuple, tuple, dict]:
    hdr = img.header
    zooms = list(hdr.get_zooms())
    spacing = _spacing3((zooms + [1.0, 1.0, 1.0])[:3][::-1])
    affine = np.asarray(img.affine, dtype=float)
    origin = _origin3(affine[:3, 3][::-1])
    meta: dict[str, Any] = {}
    for ext in getattr(hdr, "extensions", ()):
        if ext.get_code() == _NIFTI_COMMENT:
            found = _meta_from_json(ext.get_content()).get("volpack_meta")
            if isinstance(found, dict):
                meta.update(found)
    meta.update(source_format="nifti", nifti_affine=jsonable(affine))
    meta.pop("nifti_scl", None)
    meta.pop("nifti_tr", None)
    if len(img.shape) >= 4 and len(zooms) >= 4 and img.shape[3] > 1:
        meta["nifti_tr"] = float(zooms[3])
    slope = getattr(img.dataobj, "slope", 1.0)
    inter = getattr(img.dataobj, "inter", 0.0)
    if slope is not None and inter is not None and (float(slope), float(inter)) != (1.0, 0.0):
        meta["nifti_scl"] = [float(slope), float(inter)]
    return spacing, origin, meta


def _read_nifti(path: str, max_voxels: int) -> Volume:
    """Stored values, never scaled: ``meta['nifti_scl'] = [slope, inter]`` says how to get
    the physical value (``stored * slope + inter``) and is written back on output."""
    img = _nifti_load(path)
    shape = _nifti_shape(img)
    _check_voxels(shape, max_voxels, path)
    spacing, origin, meta = _nifti_geometry(img)
    obj = img.dataobj
    arr = np.asanyarray(obj.get_unscaled() if hasattr(obj, "get_unscaled") else obj)
    arr = arr.reshape(shape[::-1] if len(shape) == 3 else (*shape[1:][::-1], shape[0]))
    arr = _xyz_to_zyx(arr)
    return Volume(_as_volume_array(arr, meta, path), spacing=spacing, origin=origin, meta=meta)


def _nifti_header(path: str) -> dict[str, Any]:
    img = _nifti_load(path)
    spacing, origin, meta = _nifti_geometry(img)
    return _header_dict(
        "nifti", _nifti_shape(img), _native(img.header.get_data_dtype()), spacing, origin, meta
    )


def _write_nifti(vol: Volume, path: str, force: bool) -> None:
    import nibabel as nib

    from ..format.atomic import atomic_path

    sz, sy, sx = vol.spacing
    oz, oy, ox = vol.origin
    affine = np.diag([sx, sy, sz, 1.0])
    affine[:3, 3] = (ox, oy, oz)
    old = vol.meta.get("nifti_affine")
    if old is not None:  # keep the orientation when geometry is unchanged
        try:
            a = np.asarray(old, dtype=float)
            zooms = np.sqrt((a[:3, :3] ** 2).sum(axis=0))
            if (
                a.shape == (4, 4)
                and np.allclose(zooms, (sx, sy, sz))
                and np.allclose(a[:3, 3], (ox, oy, oz))
            ):
                affine = a
        except (TypeError, ValueError):
            pass
    data = vol.data.transpose(tuple(range(vol.data.ndim - 1, -1, -1)))
    _refuse_float16(vol, "NIfTI")
    img = nib.Nifti1Image(data, affine, dtype=vol.dtype)
    img.header.set_data_dtype(vol.dtype)
    if vol.data.ndim == 4:
        img.header.set_zooms((sx, sy, sz, float(vol.meta.get("nifti_tr", 1.0))))
    scl = vol.meta.get("nifti_scl")
    if scl is not None and vol.dtype.kind in "iu":
        img.header.set_slope_inter(float(scl[0]), float(scl[1]))
    keep = {k: v for k, v in vol.meta.items() if k not in ("nifti_affine", "nifti_scl", "nifti_tr")}
    if keep:
        text = json.dumps({"volpack_meta": jsonable(keep)}, sort_keys=True)
        img.header.extensions.append(nib.nifti1.Nifti1Extension(_NIFTI_COMMENT, text.encode()))
    suffix = ".nii.gz" if path.lower().endswith(".gz") else ".nii"
    with atomic_path(path, force=force, suffix=suffix) as tmp:
        img.to_filename(tmp)


# -- NRRD ------------------------------------------------------------------------------

_NRRD_TYPES = {
    "i1": ("signed char", "int8", "int8_t"),
    "u1": ("uchar", "unsigned char", "uint8", "uint8_t"),
    "i2": ("short", "short int", "signed short", "signed short int", "int16", "int16_t"),
    "u2": ("ushort", "unsigned short", "unsigned short int", "uint16", "uint16_t"),
    "i4": ("int", "signed int", "int32", "int32_t"),
    "u4": ("uint", "unsigned int", "uint32", "uint32_t"),
    "i8": (
        "longlong",
        "long long",
        "long long int",
        "signed long long",
        "signed long long int",
        "int64",
        "int64_t",
    ),
    "u8": ("ulonglong", "unsigned long long", "unsigned long long int", "uint64", "uint64_t"),
    "f4": ("float",),
    "f8": ("double",),
}
_NRRD_DTYPE = {name: code for code, names in _NRRD_TYPES.items() for name in names}


def _nrrd_geometry(header: dict, path: str) -> tuple[tuple[int, ...], tuple, tuple, dict]:
    sizes = [int(s) for s in header.get("sizes", [])]
    if len(sizes) not in (2, 3, 4):
        raise FormatError(f"expected a 3-D or 4-D NRRD in {path!r}, found sizes {sizes}")
    spacing_xyz: list[float] = []
    if header.get("space directions") is not None:
        for row in header["space directions"]:
            r = np.asarray(row, dtype=float) if row is not None else np.array([np.nan])
            if np.all(np.isfinite(r)):
                spacing_xyz.append(float(np.sqrt((r**2).sum())))
    elif header.get("spacings") is not None:
        spacing_xyz = [float(s) for s in header["spacings"] if math.isfinite(float(s))]
    origin_xyz = [float(v) for v in header.get("space origin", [])][:3]
    shape = tuple(sizes[::-1])
    if len(shape) == 2:
        shape = (1, *shape)
    spacing = _spacing3(spacing_xyz[:3][::-1])
    origin = _origin3(origin_xyz[::-1]) if origin_xyz else (0.0, 0.0, 0.0)
    meta: dict[str, Any] = {}
    if "volpack_meta" in header:
        meta.update(_meta_from_json(header["volpack_meta"]))
    meta["source_format"] = "nrrd"
    for key in ("space", "kinds"):
        if key in header:
            meta[f"nrrd_{key.replace(' ', '_')}"] = jsonable(header[key])
    return shape, spacing, origin, meta


def _read_nrrd(path: str, max_voxels: int) -> Volume:
    import nrrd

    with open(path, "rb") as fh:
        header = nrrd.read_header(fh)
        shape, spacing, origin, meta = _nrrd_geometry(header, path)
        _check_voxels(shape, max_voxels, path)
        arr = nrrd.read_data(header, fh, filename=path, index_order="C")
    arr = np.asarray(arr).reshape(shape)
    return Volume(_as_volume_array(arr, meta, path), spacing=spacing, origin=origin, meta=meta)


def _nrrd_header(path: str) -> dict[str, Any]:
    import nrrd

    with open(path, "rb") as fh:
        header = nrrd.read_header(fh)
    shape, spacing, origin, meta = _nrrd_geometry(header, path)
    code = _NRRD_DTYPE.get(str(header.get("type", "")).strip())
    if code is None:
        raise FormatError(f"expected a numeric NRRD type in {path!r}, found {header.get('type')!r}")
    return _header_dict("nrrd", shape, _native(code), spacing, origin, meta)


def _write_nrrd(vol: Volume, path: str, force: bool) -> None:
    import nrrd

    from ..format.atomic import atomic_path

    _refuse_float16(vol, "NRRD")
    ndim = vol.data.ndim
    directions = np.full((ndim, 3), np.nan)
    directions[:3, :3] = np.diag(vol.spacing[::-1])
    header: dict[str, Any] = {
        "space dimension": 3,
        "space directions": directions,
        "space origin": np.asarray(vol.origin[::-1], dtype=float),
        "kinds": ["domain"] * 3 + (["list"] if ndim == 4 else []),
        "encoding": "gzip",
    }
    text = _meta_json(vol)
    if text is not None:
        header["volpack_meta"] = text
    with atomic_path(path, force=force, suffix=".nrrd") as tmp:
        nrrd.write(tmp, vol.data, header, index_order="C")


# -- HDF5 ------------------------------------------------------------------------------


def _h5_pick(f, inner: str | None, path: str):
    import h5py

    if inner is not None:
        if inner not in f:
            raise FormatError(f"expected a dataset {inner!r} in {path!r}, found none there")
        ds = f[inner]
        if not isinstance(ds, h5py.Dataset):
            raise FormatError(f"expected {inner!r} in {path!r} to be a dataset, found a group")
        return ds
    found: list[str] = []
    f.visititems(
        lambda name, obj: found.append("/" + name) if isinstance(obj, h5py.Dataset) else None
    )
    if DEFAULT_H5_DATASET in found:
        return f[DEFAULT_H5_DATASET]
    if len(found) == 1:
        return f[found[0]]
    listed = ", ".join(found[:10]) or "none"
    raise FormatError(
        f"expected one dataset or {DEFAULT_H5_DATASET!r} in {path!r} (name it as "
        f"{path}:/path), found {listed}"
    )


def _h5_geometry(ds) -> tuple[tuple, tuple, dict]:
    attrs = ds.attrs
    meta: dict[str, Any] = {}
    if "volpack_meta" in attrs:
        meta.update(_meta_from_json(attrs["volpack_meta"]))
    meta["source_format"] = "hdf5"
    meta["hdf5_dataset"] = ds.name
    spacing: tuple = (1.0, 1.0, 1.0)
    for key in ("spacing", "element_size_um"):
        if key in attrs:
            spacing = _spacing3(np.atleast_1d(attrs[key])[-3:])
            if key == "element_size_um":
                meta["spacing_unit"] = "um"
            break
    origin = _origin3(np.atleast_1d(attrs["origin"])[-3:]) if "origin" in attrs else (0.0,) * 3
    return spacing, origin, meta


def _h5_shape(ds, path: str) -> tuple[int, ...]:
    shape = tuple(int(s) for s in ds.shape)
    if len(shape) == 2:
        shape = (1, *shape)
    if len(shape) not in (3, 4):
        raise FormatError(
            f"expected a 3-D (z, y, x) or 4-D (t, z, y, x) dataset {ds.name!r} in {path!r}, "
            f"found shape {tuple(ds.shape)}"
        )
    return shape


def _read_hdf5(path: str, inner: str | None, max_voxels: int) -> Volume:
    import h5py

    with h5py.File(path, "r") as f:
        ds = _h5_pick(f, inner, path)
        shape = _h5_shape(ds, path)
        _check_voxels(shape, max_voxels, path)
        spacing, origin, meta = _h5_geometry(ds)
        arr = ds[()]
    arr = np.asarray(arr).reshape(shape)
    return Volume(_as_volume_array(arr, meta, path), spacing=spacing, origin=origin, meta=meta)


def _hdf5_header(path: str, inner: str | None) -> dict[str, Any]:
    import h5py

    with _wrap("hdf5", path), h5py.File(path, "r") as f:
        ds = _h5_pick(f, inner, path)
        spacing, origin, meta = _h5_geometry(ds)
        if ds.dtype.kind not in "biuf":
            raise FormatError(f"expected integer or float voxels in {path!r}, found {ds.dtype}")
        return _header_dict("hdf5", _h5_shape(ds, path), _native(ds.dtype), spacing, origin, meta)


def _write_hdf5(vol: Volume, path: str, inner: str, force: bool) -> None:
    import h5py

    from ..format.atomic import atomic_path

    with _wrap("hdf5", path, writing=True), atomic_path(path, force=force, suffix=".h5") as tmp:
        keep = os.path.exists(path) and h5py.is_hdf5(path)
        if keep:  # replace one dataset, keep the rest of the file
            shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a" if keep else "w") as f:
            if inner in f:
                del f[inner]
            ds = f.create_dataset(inner, data=vol.data)
            ds.attrs["spacing"] = np.asarray(vol.spacing, dtype=np.float64)
            ds.attrs["origin"] = np.asarray(vol.origin, dtype=np.float64)
            text = _meta_json(vol)
            if text is not None:
                ds.attrs["volpack_meta"] = text


# -- TIFF ------------------------------------------------------------------------------


def _tiff_xy_spacing(page) -> tuple[float, float]:
    """(y, x) pixel size from the resolution tags (1 when absent)."""
    out = []
    for name in ("YResolution", "XResolution"):
        tag = page.tags.get(name)
        v = 1.0
        if tag is not None:
            try:
                num, den = tag.value
                v = den / num if num else 1.0
            except (TypeError, ValueError, ZeroDivisionError):
                v = 1.0
        out.append(v)
    return out[0], out[1]


def _tiff_open(path: str):
    import tifffile

    return tifffile.TiffFile(path)


def _tiff_geometry(tif, path: str) -> tuple[tuple[int, ...], np.dtype, tuple, tuple, dict]:
    series = tif.series[0]
    axes = series.axes
    if "S" in axes or ("C" in axes and series.shape[axes.index("C")] > 1):
        raise FormatError(
            f"expected a grayscale TIFF in {path!r}, found axes {axes!r} shape {series.shape}"
        )
    shape = tuple(int(s) for s, a in zip(series.shape, axes) if not (a in "SC" and s == 1))
    if len(shape) == 2:
        shape = (1, *shape)
    if len(shape) not in (3, 4):
        raise FormatError(
            f"expected a 3-D or 4-D TIFF stack in {path!r}, found axes {axes!r} shape {series.shape}"
        )
    meta: dict[str, Any] = {"source_format": "tiff"}
    spacing: tuple = (1.0, 1.0, 1.0)
    origin: tuple = (0.0, 0.0, 0.0)
    shaped = tif.shaped_metadata[0] if tif.is_shaped and tif.shaped_metadata else None
    if shaped and "spacing" in shaped:
        spacing = _spacing3(shaped["spacing"])
        if "origin" in shaped:
            origin = _origin3(shaped["origin"])
        if isinstance(shaped.get("volpack_meta"), dict):
            meta.update(shaped["volpack_meta"])
            meta["source_format"] = "tiff"
    else:
        ys, xs = _tiff_xy_spacing(tif.pages[0])
        zs = 1.0
        ij = tif.imagej_metadata if tif.is_imagej else None
        if ij and "spacing" in ij:
            zs = float(ij["spacing"])
        spacing = _spacing3((zs, ys, xs))
    return shape, _native(series.dtype), spacing, origin, meta


def _read_tiff(path: str, max_voxels: int) -> Volume:
    with _tiff_open(path) as tif:
        shape, _, spacing, origin, meta = _tiff_geometry(tif, path)
        _check_voxels(shape, max_voxels, path)
        arr = tif.series[0].asarray()
    arr = np.asarray(arr).reshape(shape)
    return Volume(_as_volume_array(arr, meta, path), spacing=spacing, origin=origin, meta=meta)


def _tiff_header(path: str) -> dict[str, Any]:
    with _tiff_open(path) as tif:
        shape, dtype, spacing, origin, meta = _tiff_geometry(tif, path)
    return _header_dict("tiff", shape, dtype, spacing, origin, meta)


def _write_tiff(vol: Volume, path: str, force: bool) -> None:
    import tifffile

    from ..format.atomic import atomic_path

    metadata: dict[str, Any] = {
        "axes": "ZYX" if vol.data.ndim == 3 else "TZYX",
        "spacing": list(vol.spacing),
        "origin": list(vol.origin),
    }
    if vol.meta:
        metadata["volpack_meta"] = jsonable(vol.meta)
    sy, sx = vol.spacing[1], vol.spacing[2]
    with atomic_path(path, force=force, suffix=".tif") as tmp:
        tifffile.imwrite(
            tmp,
            vol.data,
            photometric="minisblack",
            metadata=metadata,
            resolution=(1.0 / sx, 1.0 / sy),
        )


def _natural_key(name: str) -> list:
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)]


def _read_tiff_folder(path: str, max_voxels: int) -> Volume:
    import tifffile

    names = sorted(
        (n for n in os.listdir(path) if n.lower().endswith(_TIFF_EXTS) and not n.startswith(".")),
        key=_natural_key,
    )
    if not names:
        raise FormatError(f"expected .tif/.tiff slices in {path!r}, found none")
    with tifffile.TiffFile(os.path.join(path, names[0])) as tif:
        first = tif.series[0]
        yx = tuple(int(s) for s in first.shape)
        dtype = first.dtype
        ys, xs = _tiff_xy_spacing(tif.pages[0])
    if len(yx) != 2:
        raise FormatError(
            f"expected 2-D grayscale slices in {path!r}, found {names[0]!r} with shape {yx}"
        )
    _check_voxels((len(names), *yx), max_voxels, path)
    out = np.empty((len(names), *yx), dtype=dtype)
    for i, name in enumerate(names):
        sl = tifffile.imread(os.path.join(path, name))
        if sl.shape != yx or sl.dtype != dtype:
            raise FormatError(
                f"expected every slice in {path!r} to be {yx} {dtype} like {names[0]!r}, "
                f"found {name!r} {sl.shape} {sl.dtype}"
            )
        out[i] = sl
    meta: dict[str, Any] = {"source_format": "tiff-folder", "slices": len(names)}
    return Volume(_as_volume_array(out, meta, path), spacing=_spacing3((1.0, ys, xs)), meta=meta)


# -- DICOM -----------------------------------------------------------------------------


def _pydicom():
    try:
        import pydicom
    except ImportError:
        raise FormatError(
            "expected pydicom for DICOM input, found it missing: pip install 'volpack[dicom]'"
        ) from None
    return pydicom


def _read_dicom(path: str, max_voxels: int) -> Volume:
    pydicom = _pydicom()
    from pydicom.errors import InvalidDicomError

    if os.path.isdir(path):
        files = [
            os.path.join(path, n)
            for n in sorted(os.listdir(path), key=_natural_key)
            if not n.startswith(".") and os.path.isfile(os.path.join(path, n))
        ]
    else:
        files = [path]
    headers = []
    for fn in files:
        try:
            ds = pydicom.dcmread(fn, stop_before_pixels=True)
        except (InvalidDicomError, EOFError, OSError):
            if len(files) == 1:
                raise
            continue  # DICOMDIR, README and friends
        if "Rows" in ds and "Columns" in ds:
            headers.append((fn, ds))
    if not headers:
        raise FormatError(f"expected DICOM images in {path!r}, found none")
    frames = int(getattr(headers[0][1], "NumberOfFrames", 1) or 1)
    rows, cols = int(headers[0][1].Rows), int(headers[0][1].Columns)
    nslices = frames if len(headers) == 1 else len(headers)
    _check_voxels((nslices, rows, cols), max_voxels, path)

    normal = None
    iop = getattr(headers[0][1], "ImageOrientationPatient", None)
    if iop is not None and len(iop) == 6:
        r, c = np.asarray(iop[:3], float), np.asarray(iop[3:], float)
        normal = np.cross(r, c)

    def position(item):
        _, ds = item
        ipp = getattr(ds, "ImagePositionPatient", None)
        if ipp is not None and len(ipp) == 3 and normal is not None:
            return (0, float(np.dot(normal, np.asarray(ipp, float))), 0)
        return (1, 0.0, int(getattr(ds, "InstanceNumber", 0) or 0))

    headers.sort(key=position)
    slices = []
    slopes, inters = [], []
    for fn, _ in headers:
        ds = pydicom.dcmread(fn)
        px = ds.pixel_array
        if px.ndim == 3 and frames == 1 or px.ndim > 3:
            raise FormatError(
                f"expected grayscale DICOM slices in {path!r}, found {fn!r} {px.shape}"
            )
        slices.append(px if px.ndim == 3 else px[np.newaxis])
        slopes.append(float(getattr(ds, "RescaleSlope", 1) or 1))
        inters.append(float(getattr(ds, "RescaleIntercept", 0) or 0))
    shapes = {s.shape[1:] for s in slices}
    if len(shapes) != 1:
        raise FormatError(f"expected DICOM slices of one size in {path!r}, found {sorted(shapes)}")
    arr = np.concatenate(slices, axis=0)

    first = headers[0][1]
    ps = getattr(first, "PixelSpacing", None)
    ys, xs = (float(ps[0]), float(ps[1])) if ps is not None and len(ps) == 2 else (1.0, 1.0)
    zs = float(
        getattr(first, "SpacingBetweenSlices", 0) or getattr(first, "SliceThickness", 0) or 1
    )
    if len(headers) > 1 and normal is not None:
        pos = [position(h)[1] for h in headers if position(h)[0] == 0]
        if len(pos) == len(headers):
            d = np.diff(pos)
            if d.size and np.median(d) > 0:
                zs = float(np.median(d))
    ipp = getattr(first, "ImagePositionPatient", None)
    origin = _origin3(list(ipp)[::-1]) if ipp is not None and len(ipp) == 3 else (0.0,) * 3

    meta: dict[str, Any] = {"source_format": "dicom", "dicom_files": len(headers)}
    if getattr(first, "Modality", None):
        meta["dicom_modality"] = str(first.Modality)
    if len(set(slopes)) == 1 and len(set(inters)) == 1:
        slope, inter = slopes[0], inters[0]
        applied = False
        if (slope, inter) != (1.0, 0.0) and slope.is_integer() and inter.is_integer():
            wide = arr.astype(np.int64) * int(slope) + int(inter)
            arr = wide.astype(_smallest_int(int(wide.min()), int(wide.max())))
            applied = True
        if (slope, inter) != (1.0, 0.0):
            meta["dicom_rescale"] = {"slope": slope, "intercept": inter, "applied": applied}
    else:
        meta["dicom_rescale"] = {"slopes": slopes, "intercepts": inters, "applied": False}
    return Volume(
        _as_volume_array(arr, meta, path), spacing=_spacing3((zs, ys, xs)), origin=origin, meta=meta
    )


def _smallest_int(lo: int, hi: int) -> np.dtype:
    for name in ("uint8", "int8", "uint16", "int16", "uint32", "int32"):
        info = np.iinfo(name)
        if info.min <= lo and hi <= info.max:
            return np.dtype(name)
    return np.dtype(np.int64)


_READERS = {
    "npy": _read_npy,
    "raw": _read_raw,
    "den": _read_den,
    "nifti": _read_nifti,
    "nrrd": _read_nrrd,
    "hdf5": _read_hdf5,
    "tiff": _read_tiff,
    "tiff-folder": _read_tiff_folder,
    "dicom": _read_dicom,
}
_HEADERS = {
    "npy": _npy_header,
    "den": _den_header,
    "nifti": _nifti_header,
    "nrrd": _nrrd_header,
    "tiff": _tiff_header,
}
_WRITERS = {
    "npy": _write_npy,
    "raw": _write_raw,
    "den": _write_den,
    "nifti": _write_nifti,
    "nrrd": _write_nrrd,
    "tiff": _write_tiff,
}
