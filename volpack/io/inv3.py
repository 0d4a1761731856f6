"""InVesalius 3 projects (``.inv3``, read only): a gzip-compressed tar holding
``main.plist`` and the voxels it names.

``main.plist`` gives the voxel file (``matrix.filename``), its shape ``(z, y, x)`` and
dtype (``matrix.shape``, ``matrix.dtype``; written by numpy on a little-endian machine,
x fastest) and the spacing ``(x, y, z)``. The project's masks and surfaces are not read.
"""

from __future__ import annotations

import math
import os
import plistlib
import tarfile
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, geometry_xyz, header_dict, native, to_volume


def _project(tar: tarfile.TarFile, path: str) -> dict[str, Any]:
    """The voxels' member, shape, dtype and spacing that ``main.plist`` records."""
    members = {os.path.basename(m.name): m for m in tar.getmembers() if m.isfile()}
    if "main.plist" not in members:
        raise FormatError(f"expected an InVesalius project with main.plist in {path!r}, found none")
    plist = plistlib.loads(tar.extractfile(members["main.plist"]).read())
    matrix = plist.get("matrix") if isinstance(plist, dict) else None
    try:
        shape = tuple(int(n) for n in matrix["shape"])
        dtype = np.dtype(str(matrix["dtype"])).newbyteorder("<")
        member = members[os.path.basename(str(matrix["filename"]))]
        spacing_xyz = [float(s) for s in plist["spacing"]]
    except (KeyError, TypeError, ValueError) as e:
        raise FormatError(
            f"expected a matrix (filename, shape, dtype) and a spacing in the main.plist of "
            f"{path!r}, found {e!r}"
        ) from None
    if len(shape) != 3 or min(shape) <= 0 or dtype.kind not in "iuf":
        raise FormatError(
            f"expected a 3-D integer or float matrix in {path!r}, found shape {shape} of {dtype}"
        )
    spacing, _ = geometry_xyz(spacing_xyz, (0.0, 0.0, 0.0))
    meta = {"source_format": "inv3"}
    if isinstance(plist.get("modality"), str):
        meta["inv3_modality"] = plist["modality"]
    return {"member": member, "shape": shape, "dtype": dtype, "spacing": spacing, "meta": meta}


def read(path: str, opts: ReadOptions) -> Volume:
    with tarfile.open(path, "r:gz") as tar:
        p = _project(tar, path)
        check_voxels(p["shape"], opts.max_voxels, path)
        n = math.prod(p["shape"]) * p["dtype"].itemsize
        blob = tar.extractfile(p["member"]).read(n + 1)  # one more: trailing bytes are wrong
    if len(blob) != n:
        raise FormatError(
            f"expected {n} bytes of {p['dtype']} voxels for {p['shape']} in {path!r}, "
            f"found {len(blob) if len(blob) < n else 'more'}"
        )
    arr = np.frombuffer(blob, p["dtype"])
    return to_volume(arr, p["meta"], path, p["shape"], p["spacing"])


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with tarfile.open(path, "r:gz") as tar:
        p = _project(tar, path)
    return header_dict("inv3", p["shape"], native(p["dtype"]), p["spacing"], (0.0, 0.0, 0.0))
