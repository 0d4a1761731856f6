"""MRC / CCP4 density maps (cryo-EM, crystallography, tomography) through mrcfile
(``mrc`` extra): ``.mrc``, ``.map``, ``.ccp4``, ``.mrcs``, gzip or bzip2 compressed or not.

The file stores sections, rows and columns in the axis order its header names (``mapc``,
``mapr``, ``maps``; crystallographic maps often differ from x, y, z); the reader turns
them to volpack's ``(z, y, x)`` so that spacing and rendering agree with the map's own
axes, and keeps the stored order in ``meta``. Spacing is the voxel size (usually
angstroms), the origin the header's, else the start indices times the voxel size.
Volume stacks (space group 401) come back as ``(t, z, y, x)``. Writes ``.mrc``, ``.map``,
``.ccp4``, ``.mrcs`` in x, y, z order (MRC2014); MRC has no uint8, int32 or float64 mode:
uint8 maps are stored as uint16 (the values unchanged), the other two are refused.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, header_dict, native, origin3, spacing3, to_volume

WRITES = (".mrc", ".map", ".ccp4", ".mrcs")
_MODES = {"int8", "uint8", "int16", "uint16", "float16", "float32"}


def _mrcfile():
    try:
        import mrcfile
    except ImportError:
        raise FormatError(
            "expected mrcfile for MRC/CCP4 maps, found it missing: pip install 'volpack[mrc]'"
        ) from None
    return mrcfile


def _layout(m, path: str) -> tuple[tuple[int, ...], tuple, tuple, dict]:
    """The array axes that hold z, y and x, spacing, origin and meta of an open map."""
    h = m.header
    labels = (int(h.maps), int(h.mapr), int(h.mapc))  # what array axes 0, 1, 2 hold
    if sorted(labels) != [1, 2, 3]:
        raise FormatError(
            f"expected the map's axes (mapc, mapr, maps) to be 1, 2, 3 in some order in "
            f"{path!r}, found {labels[::-1]}"
        )
    axes = tuple(labels.index(a) for a in (3, 2, 1))  # array axes holding z, y, x
    size = m.voxel_size
    spacing = spacing3((float(size.z), float(size.y), float(size.x)))
    origin_xyz = [float(h.origin.x), float(h.origin.y), float(h.origin.z)]
    if not any(origin_xyz):  # MRC2014 puts a subvolume's place in the start indices
        start = {
            int(h.mapc): int(h.nxstart),
            int(h.mapr): int(h.nystart),
            int(h.maps): int(h.nzstart),
        }
        step = (float(size.x), float(size.y), float(size.z))
        origin_xyz = [start[a] * step[a - 1] for a in (1, 2, 3)]
    meta: dict[str, Any] = {
        "source_format": "mrc",
        "mrc_mode": int(h.mode),
        "mrc_axis_order": [int(h.mapc), int(h.mapr), int(h.maps)],
        "mrc_space_group": int(h.ispg),
    }
    return axes, spacing, origin3(origin_xyz[::-1]), meta


def _open(path: str):
    return _mrcfile().open(path, mode="r", permissive=False)


def _zyx(shape: tuple[int, ...], axes: tuple[int, ...]) -> tuple[int, ...]:
    """The shape in volpack's order; a volume stack keeps its leading volume axis."""
    if len(shape) == 4:
        return (shape[0], *(shape[a + 1] for a in axes))
    return tuple(shape[a] for a in axes)


def read(path: str, opts: ReadOptions) -> Volume:
    with _open(path) as m:
        axes, spacing, origin, meta = _layout(m, path)
        shape = tuple(int(n) for n in m.data.shape)
        check_voxels(shape, opts.max_voxels, path)
        data = np.asarray(m.data)
    if data.dtype.kind == "c":
        raise FormatError(f"expected real voxels in {path!r}, found {data.dtype} (a Fourier map)")
    if data.ndim == 4:  # a volume stack: the axis order applies to each volume
        data = data.transpose(0, *(a + 1 for a in axes))
    elif data.ndim == 3:
        data = data.transpose(axes)
    return to_volume(data, meta, path, None, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    mrcfile = _mrcfile()
    packed = path.lower().endswith((".gz", ".bz2"))  # no memory map through a decompressor
    with _open(path) if packed else mrcfile.mmap(path, mode="r", permissive=False) as m:
        axes, spacing, origin, meta = _layout(m, path)
        shape, dtype = tuple(int(n) for n in m.data.shape), np.dtype(m.data.dtype)
    return header_dict("mrc", _zyx(shape, axes), native(dtype), spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_path

    if vol.dtype.name not in _MODES:
        raise FormatError(
            f"expected int8, uint8, int16, uint16, float16 or float32 voxels for an MRC map, "
            f"found {vol.dtype}; convert them first (astype='float32'; astype='uint16' or "
            f"astype='int16' when the values fit: out-of-range ones are clipped and counted)"
        )
    mrcfile = _mrcfile()
    data = vol.data.astype(np.uint16) if vol.dtype == np.uint8 else vol.data
    with atomic_path(path, force=force, suffix=".mrc") as tmp:
        with mrcfile.new(tmp, overwrite=True) as m:
            m.set_data(np.ascontiguousarray(data))
            m.voxel_size = tuple(float(s) for s in vol.spacing[::-1])
            m.header.origin = tuple(float(o) for o in vol.origin[::-1])
