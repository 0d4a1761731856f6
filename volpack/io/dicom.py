"""DICOM: a folder of slices or one multi-frame file, through pydicom (``dicom`` extra)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, as_volume_array, check_voxels, natural_key, origin3, spacing3


def _pydicom():
    try:
        import pydicom
    except ImportError:
        raise FormatError(
            "expected pydicom for DICOM input, found it missing: pip install 'volpack[dicom]'"
        ) from None
    return pydicom


def read(path: str, opts: ReadOptions) -> Volume:
    pydicom = _pydicom()
    from pydicom.errors import InvalidDicomError

    if os.path.isdir(path):
        files = [
            os.path.join(path, n)
            for n in sorted(os.listdir(path), key=natural_key)
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
    check_voxels((nslices, rows, cols), opts.max_voxels, path)

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
    origin = origin3(list(ipp)[::-1]) if ipp is not None and len(ipp) == 3 else (0.0,) * 3

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
        as_volume_array(arr, meta, path), spacing=spacing3((zs, ys, xs)), origin=origin, meta=meta
    )


def _smallest_int(lo: int, hi: int) -> np.dtype:
    for name in ("uint8", "int8", "uint16", "int16", "uint32", "int32"):
        info = np.iinfo(name)
        if info.min <= lo and hi <= info.max:
            return np.dtype(name)
    return np.dtype(np.int64)
