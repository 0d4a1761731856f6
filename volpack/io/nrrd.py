"""NRRD (``.nrrd`` and detached ``.nhdr``) through pynrrd."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import FormatError
from ..jsonsafe import jsonable
from ..volume import Volume
from .common import (
    ReadOptions,
    check_voxels,
    geometry_xyz,
    header_dict,
    meta_json,
    native,
    refuse_float16,
    stored_meta,
    to_volume,
)

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
    spacing, origin = geometry_xyz(spacing_xyz, origin_xyz)
    meta = stored_meta(header, "nrrd")
    for key in ("space", "kinds"):
        if key in header:
            meta[f"nrrd_{key.replace(' ', '_')}"] = jsonable(header[key])
    return shape, spacing, origin, meta


def read(path: str, opts: ReadOptions) -> Volume:
    import nrrd

    with open(path, "rb") as fh:
        header = nrrd.read_header(fh)
        shape, spacing, origin, meta = _nrrd_geometry(header, path)
        check_voxels(shape, opts.max_voxels, path)
        arr = nrrd.read_data(header, fh, filename=path, index_order="C")
    return to_volume(arr, meta, path, shape, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    import nrrd

    with open(path, "rb") as fh:
        header = nrrd.read_header(fh)
    shape, spacing, origin, meta = _nrrd_geometry(header, path)
    code = _NRRD_DTYPE.get(str(header.get("type", "")).strip())
    if code is None:
        raise FormatError(f"expected a numeric NRRD type in {path!r}, found {header.get('type')!r}")
    return header_dict("nrrd", shape, native(code), spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    import nrrd

    from ..format.atomic import atomic_path

    refuse_float16(vol, "NRRD")
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
    text = meta_json(vol)
    if text is not None:
        header["volpack_meta"] = text
    with atomic_path(path, force=force, suffix=".nrrd") as tmp:
        nrrd.write(tmp, vol.data, header, index_order="C")
