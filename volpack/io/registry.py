"""The formats volpack reads and writes, by name and file suffix.

A :class:`Format` names the module that implements it (imported on first use, so
``volpack --help`` and a ``.vpk`` decode never import nibabel, h5py or tifffile) and the
suffixes it claims. A format module provides ``read(path, opts)``, and where the format
allows, ``header(path, opts)`` (reads only the header) and ``write(vol, path, force,
inner)``.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
from types import ModuleType

from ..errors import FormatError

_HDF5_EXTS = (".h5", ".hdf5", ".hdf")
_NETCDF_EXTS = (".nc", ".cdf", ".nc4")
_TIFF_EXTS = (".tif", ".tiff")
_ZARR_MARKERS = ("zarr.json", ".zarray", ".zgroup")  # a zarr store's metadata at its top
_MRC_EXTS = (".mrc", ".map", ".ccp4", ".mrcs") + tuple(
    e + z for e in (".mrc", ".map", ".ccp4") for z in (".gz", ".bz2")
)


@dataclasses.dataclass(frozen=True)
class Format:
    name: str
    module: str  # volpack.io.<module>
    extensions: tuple[str, ...] = ()
    writes: tuple[str, ...] = ()  # output suffixes; empty: read-only
    read: str = "read"
    header: str | None = "header"  # None: read_header reads the whole volume

    def load(self) -> ModuleType:
        return importlib.import_module(f"{__package__}.{self.module}")

    def function(self, name: str):
        return getattr(self.load(), name)


FORMATS: dict[str, Format] = {}


def register(fmt: Format) -> None:
    """Add (or replace) a format; its suffixes then win over earlier claims."""
    FORMATS[fmt.name] = fmt


for _f in (
    Format("npy", "npy", (".npy",), (".npy",)),
    # .img becomes "nifti" when a sibling .hdr exists (Analyze 7.5)
    Format("raw", "raw", (".raw", ".bin", ".img"), (".raw", ".bin", ".img")),
    Format("nifti", "nifti", (".nii", ".nii.gz", ".hdr"), (".nii", ".nii.gz")),
    # the other formats nibabel reads, through the NIfTI reader (read-only)
    Format("mgh", "nifti", (".mgh", ".mgz")),
    Format("minc", "nifti", (".mnc",), header=None),
    Format("afni", "nifti", (".head", ".brik", ".brik.gz"), header=None),
    Format("parrec", "nifti", (".par", ".rec"), header=None),
    Format("nrrd", "nrrd", (".nrrd", ".nhdr"), (".nrrd",)),
    Format("hdf5", "hdf5", _HDF5_EXTS, _HDF5_EXTS),
    # netCDF-4 files go on to the HDF5 reader; classic ones need the netCDF4 library
    Format("netcdf", "netcdf", _NETCDF_EXTS, (".nc",)),
    Format("tiff", "tiff", _TIFF_EXTS, _TIFF_EXTS),
    Format("tiff-folder", "tiff", read="read_folder", header=None),
    Format("png", "png", (".png",)),  # one greyscale slice (read-only)
    Format("png-folder", "png", read="read_folder", header=None),
    Format("metaimage", "metaimage", (".mha", ".mhd"), (".mha", ".mhd")),
    Format("vti", "vti", (".vti",), (".vti",)),
    Format("inr", "inr", (".inr", ".inr.gz"), (".inr", ".inr.gz")),
    Format("den", "den", (".den",), (".den",)),
    Format("dicom", "dicom", (".dcm",), header=None),
    Format("inv3", "inv3", (".inv3",)),  # InVesalius projects (read-only)
    Format("mrc", "mrc", _MRC_EXTS, _MRC_EXTS[:4]),
    Format("zarr", "zarrstore", (".zarr",), (".zarr",)),  # a folder (format 2/3, OME-Zarr)
    Format("vpk", "vpk", (".vpk",), (".vpk",)),
):
    register(_f)


def extensions() -> dict[str, str]:
    """Every claimed suffix -> format name."""
    return {ext: f.name for f in FORMATS.values() for ext in f.extensions}


def writable() -> list[str]:
    return sorted({ext for f in FORMATS.values() for ext in f.writes})


def parse_spec(spec: str) -> tuple[str, str | None]:
    """Split ``"file.h5:/group/ds"`` into ``("file.h5", "/group/ds")``.

    Only a part before ``:`` that ends in an HDF5, netCDF or zarr extension (.h5, .hdf5,
    .hdf, .nc, .cdf, .nc4, .zarr) is split off; any other spec, and ``'-'``, comes back
    as ``(spec, None)``.
    """
    spec = os.fspath(spec)
    if spec == "-":
        return "-", None
    low = spec.lower()
    for ext in _HDF5_EXTS + _NETCDF_EXTS + (".zarr",):
        i = low.find(ext + ":")
        if i >= 0:
            path, inner = spec[: i + len(ext)], spec[i + len(ext) + 1 :]
            if not inner:
                return path, None
            return path, inner if inner.startswith("/") else "/" + inner
    return spec, None


def detect_format(path: str) -> str:
    """Name the format of ``path`` from its extension (folders: from their content).

    Returns a name of :data:`FORMATS` (``npy, raw, nifti, mgh, minc, afni, parrec,
    nrrd, hdf5, netcdf, tiff, tiff-folder, png, png-folder, metaimage, vti, inr, den,
    dicom, inv3, mrc, zarr, vpk``).
    """
    path, _ = parse_spec(os.fspath(path))
    if path == "-":
        return "npy"
    if os.path.isdir(path):
        return _detect_folder(path)
    low = path.lower()
    exts = extensions()
    for ext in sorted(exts, key=len, reverse=True):
        if low.endswith(ext):
            if ext == ".img" and os.path.exists(path[:-4] + ".hdr"):
                return "nifti"
            return exts[ext]
    known = ", ".join(sorted(exts))
    raise FormatError(
        f"expected a volume file with one of the extensions {known}, a folder of TIFF, PNG "
        f"or DICOM slices, or '-' (any other file reads as raw voxels given shape and dtype), "
        f"found {path!r}"
    )


def is_zarr_store(path: str) -> bool:
    """A folder with zarr metadata at its top (read as one volume, not as slices)."""
    return os.path.isdir(path) and any(os.path.exists(os.path.join(path, m)) for m in _ZARR_MARKERS)


def _detect_folder(path: str) -> str:
    if is_zarr_store(path):
        return "zarr"
    names = [n for n in sorted(os.listdir(path)) if not n.startswith(".")]
    if any(n.lower().endswith(_TIFF_EXTS) for n in names):
        return "tiff-folder"
    if any(n.lower().endswith(".png") for n in names):
        return "png-folder"
    for n in names:
        if n.lower().endswith(".dcm") or _has_dicom_magic(os.path.join(path, n)):
            return "dicom"
    raise FormatError(
        f"expected a folder of .tif/.tiff, .png or DICOM slices, or a zarr store, found none of "
        f"them in {path!r}"
    )


def _has_dicom_magic(path: str) -> bool:
    try:
        with open(path, "rb") as f:
            f.seek(128)
            return f.read(4) == b"DICM"
    except OSError:
        return False
