"""VolPack ``.den``: 62-byte header (29 int16 and an int32 voxel count), then uint8, x fastest."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, header_dict

# 29 int16 (version, orig/extr/map min/max/len triples, warps) + int32 voxel count
_DEN_HEADER = 62
_DEN_VERSION = 1


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


def read(path: str, opts: ReadOptions) -> Volume:
    with open(path, "rb") as f:
        head = f.read(_DEN_HEADER)
        h = _den_parse(head, os.fstat(f.fileno()).st_size, path)
        check_voxels(h["shape"], opts.max_voxels, path)
        arr = np.fromfile(f, dtype=np.uint8, count=math.prod(h["shape"])).reshape(h["shape"])
    meta = {
        "source_format": "den",
        "den": {k: h[k] for k in ("orig_len", "extr_min", "extr_max", "warps", "byteorder")},
    }
    return Volume(np.ascontiguousarray(arr), meta=meta)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with open(path, "rb") as f:
        h = _den_parse(f.read(_DEN_HEADER), os.fstat(f.fileno()).st_size, path)
    return header_dict("den", h["shape"], np.uint8, (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_open

    if vol.dtype != np.uint8 or vol.data.ndim != 3:
        raise FormatError(
            f"expected a 3-D uint8 volume for a .den file, found {vol.data.ndim}-D {vol.dtype}"
            + (
                "; convert it first (astype='uint8': out-of-range values are clipped and counted)"
                if vol.data.ndim == 3
                else ""
            )
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
