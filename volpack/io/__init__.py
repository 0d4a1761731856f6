"""External volume formats in and out: npy, raw, NIfTI/Analyze, NRRD, HDF5, TIFF,
MetaImage, VTK image data, INRIMAGE, VolPack ``.den``, DICOM folders and ``.vpk``;
``'-'`` is a ``.npy`` stream on stdin/stdout.

Every reader returns a :class:`~volpack.volume.Volume` in ``(z, y, x)`` order (time
leading, ``(t, z, y, x)``), C-contiguous and in native byte order, with provenance in
``meta['source_format']`` and friends. Every failure is a :class:`FormatError` whose
message says what was expected and what was found.

One module per format (``volpack/io/<format>.py``), listed in :mod:`.registry` and
imported only when a file of that format is read or written: the heavy libraries
(nibabel, h5py, tifffile, pynrrd, pydicom) load with them, so ``volpack --help`` stays
fast.
"""

from __future__ import annotations

import os
import sys
from typing import Any

import numpy as np

from ..errors import FormatError
from ..format.streams import stdin
from ..volume import Volume
from .common import DEFAULT_MAX_VOXELS, ReadOptions, header_dict, prepare_for_write, wrap_errors
from .registry import FORMATS, detect_format, parse_spec, writable

__all__ = [
    "parse_spec", "detect_format", "output_format", "read_volume", "write_volume", "read_header",
    "list_arrays", "check_outputs",
]  # fmt: skip

DEFAULT_H5_DATASET = "/data"


def _resolve(spec: str, opts: ReadOptions) -> tuple[str, str]:
    """(path, format): a shape or dtype makes any single file raw, whatever its name."""
    path, _ = parse_spec(spec)
    raw_given = opts.shape is not None or opts.dtype is not None
    if raw_given and opts.inner is None and not os.path.isdir(path):
        return path, "raw"
    fmt = "npy" if path == "-" else detect_format(path)
    if fmt != "raw" and (raw_given or opts.offset):
        raise FormatError(
            f"expected shape= and dtype= with an offset, or neither for the "
            f"{fmt} file {path!r}, found only offset={opts.offset}"
            if not raw_given
            else f"expected shape/dtype/offset only for a single raw file, found them for "
            f"the {fmt} input {path!r}"
        )
    return path, fmt


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
        Raw input: given ``shape`` and ``dtype``, any single file (or ``'-'``) is read as
        raw voxels whatever its name. ``shape`` is ``(z, y, x)`` or ``(t, z, y, x)``, x
        fastest; ``byteorder`` ``'<'``/``'>'``; ``offset`` header bytes to skip.
    max_voxels : int
        Refuse volumes whose declared size exceeds this before allocating.
    """
    _, inner = parse_spec(spec)
    opts = ReadOptions(inner, shape, dtype, byteorder, offset, max_voxels)
    path, fmt = _resolve(spec, opts)
    if path == "-":
        if fmt == "raw":
            return FORMATS["raw"].function("read_stdin")(stdin(), opts)
        return FORMATS["npy"].function("read_stdin")(max_voxels)
    if not os.path.exists(path):
        raise FormatError(f"expected an existing {fmt} file, found nothing at {path!r}")
    f = FORMATS[fmt]
    with wrap_errors(fmt, path):
        return f.function(f.read)(path, opts)


def read_header(spec: str, **raw_options: Any) -> dict[str, Any]:
    """Return ``format``, ``shape``, ``dtype``, ``spacing`` and ``origin`` of a volume,
    reading only its header where the format allows (npy, raw, den, NIfTI, NRRD, HDF5,
    TIFF, MetaImage, VTK image data, INRIMAGE); DICOM folders, ``.vpk`` and stdin are
    read whole.

    ``dtype`` is the type :func:`read_volume` returns (native byte order).
    """
    _, inner = parse_spec(spec)
    opts = ReadOptions(inner, **{k: v for k, v in raw_options.items() if v is not None})
    path, fmt = _resolve(spec, opts)
    f = FORMATS[fmt]
    if path == "-" or f.header is None:
        vol = read_volume(spec, **raw_options)
        return header_dict(fmt, vol.shape, vol.dtype, vol.spacing, vol.origin, vol.meta)
    if not (os.path.isdir if fmt == "zarr" else os.path.isfile)(path):
        raise FormatError(f"expected an existing {fmt} file, found nothing at {path!r}")
    with wrap_errors(fmt, path):
        return f.function(f.header)(path, opts)


def list_arrays(spec: str) -> list[dict[str, Any]]:
    """The arrays of a file that holds several (HDF5, netCDF, zarr): ``name`` (what
    follows ``:`` in a spec), ``shape`` and ``dtype``, in the file's order."""
    path, _ = parse_spec(spec)
    fmt = detect_format(path) if path != "-" else "npy"
    f = FORMATS[fmt]
    if not hasattr(f.load(), "arrays"):
        raise FormatError(f"expected a file of several arrays (HDF5, netCDF, zarr), found {fmt}")
    with wrap_errors(fmt, path):
        return f.function("arrays")(path)


def check_outputs(spec: str, *, force: bool = False, inputs: tuple = ()) -> None:
    """:func:`volpack.format.atomic.check_output` for every file :func:`write_volume`
    makes for ``spec``: a ``.mhd`` header's data file too, which may be the raw input
    (``volpack convert s.raw s.mhd --force`` overwrote it)."""
    from ..format.atomic import check_output

    path = parse_spec(spec)[0]
    outputs = [path]
    if path.lower().endswith(".mhd"):
        from .metaimage import data_file

        outputs.append(data_file(path))
    for out in outputs:
        check_output(out, force=force, inputs=inputs)


def output_format(path: str) -> str:
    """The format :func:`write_volume` writes to ``path`` (a name of ``FORMATS``), or a
    FormatError naming the extensions it writes (not the ones it only reads)."""
    if not path.lower().endswith(tuple(writable())):
        raise FormatError(f"expected an output ending in {', '.join(writable())}, found {path!r}")
    return detect_format(path)


def write_volume(vol: Volume | np.ndarray, spec: str, *, force: bool = False) -> None:
    """Write a volume to ``spec``: ``.npy``, ``.raw``/``.bin``, ``.nii``/``.nii.gz``,
    ``.nrrd``, ``file.h5[:/dataset]`` (default ``/data``), ``.tif``/``.tiff``
    (multi-page), ``.mha``/``.mhd``, ``.vti``, ``.inr[.gz]``, ``.den`` (uint8 only),
    ``.vpk`` or ``'-'`` (``.npy`` to stdout).

    Files are written atomically (temporary file beside the target, then rename); an
    existing file is replaced only with ``force``. Masked float voxels are put back to
    their recorded NaN/Inf values first; a mask on integer data is not written.
    """
    if not isinstance(vol, Volume):
        vol = Volume(np.asarray(vol))
    vol = prepare_for_write(vol)
    path, inner = parse_spec(spec)
    if path == "-":
        _npy_to(sys.stdout.buffer, vol.data)
        return
    fmt = output_format(path)
    f = FORMATS[fmt]
    if not path.lower().endswith(f.writes or ("\0",)):
        raise FormatError(
            f"expected an output ending in {', '.join(writable())}, found {path!r} "
            f"({fmt} is read-only{' here' if f.writes else ''})"
        )
    if vol.dtype.kind == "b" and fmt not in ("npy", "hdf5", "netcdf", "zarr"):  # no bool
        vol = vol.replace(data=vol.data.astype(np.uint8))
    with wrap_errors(fmt, path, writing=True):
        f.function("write")(vol, path, force, inner)


def _npy_to(out, arr: np.ndarray) -> None:
    """``np.save`` to a stream, its bytes, without a copy of the voxels: ``np.save``
    itself fails on a pipe (it asks a file object for its position), and building the
    file in memory first held the volume twice more."""
    fmt = np.lib.format
    arr = np.ascontiguousarray(arr)  # the header must say the order the bytes are in
    header = fmt.header_data_from_array_1_0(arr)
    try:
        fmt.write_array_header_1_0(out, header)
    except ValueError:  # a header too long for version 1.0 (as np.save)
        fmt.write_array_header_2_0(out, header)
    out.write(memoryview(arr.reshape(-1)).cast("B"))
    out.flush()
