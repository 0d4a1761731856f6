"""TIFF: a multi-page stack through tifffile, or a folder of single-page slices."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..errors import FormatError
from ..jsonsafe import jsonable
from ..volume import Volume
from .common import (
    ReadOptions,
    check_voxels,
    folder_slices,
    header_dict,
    native,
    origin3,
    spacing3,
    to_volume,
)

_TIFF_EXTS = (".tif", ".tiff")


def xy_spacing(page) -> tuple[float, float]:
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


def geometry(tif, path: str) -> tuple[tuple[int, ...], np.dtype, tuple, tuple, dict]:
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
        spacing = spacing3(shaped["spacing"])
        if "origin" in shaped:
            origin = origin3(shaped["origin"])
        if isinstance(shaped.get("volpack_meta"), dict):
            meta.update(shaped["volpack_meta"])
            meta["source_format"] = "tiff"
    else:
        ys, xs = xy_spacing(tif.pages[0])
        zs = 1.0
        ij = tif.imagej_metadata if tif.is_imagej else None
        if ij and "spacing" in ij:
            zs = float(ij["spacing"])
        spacing = spacing3((zs, ys, xs))
    return shape, native(series.dtype), spacing, origin, meta


def read(path: str, opts: ReadOptions) -> Volume:
    with _tiff_open(path) as tif:
        shape, _, spacing, origin, meta = geometry(tif, path)
        check_voxels(shape, opts.max_voxels, path)
        arr = tif.series[0].asarray()
    return to_volume(arr, meta, path, shape, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with _tiff_open(path) as tif:
        shape, dtype, spacing, origin, meta = geometry(tif, path)
    return header_dict("tiff", shape, dtype, spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
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


def read_folder(path: str, opts: ReadOptions) -> Volume:
    import tifffile

    names = folder_slices(path, _TIFF_EXTS)
    if not names:
        raise FormatError(f"expected .tif/.tiff slices in {path!r}, found none")
    with tifffile.TiffFile(os.path.join(path, names[0])) as tif:
        first = tif.series[0]
        yx = tuple(int(s) for s in first.shape)
        dtype = first.dtype
        ys, xs = xy_spacing(tif.pages[0])
    if len(yx) != 2:
        raise FormatError(
            f"expected 2-D grayscale slices in {path!r}, found {names[0]!r} with shape {yx}"
        )
    check_voxels((len(names), *yx), opts.max_voxels, path)
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
    return to_volume(out, meta, path, spacing=spacing3((1.0, ys, xs)))
