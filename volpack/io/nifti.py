"""NIfTI-1/2 and Analyze 7.5 through nibabel; stored values, never scaled.

The other formats nibabel reads come through the same reader, read-only: FreeSurfer's
MGH/MGZ, MINC 1/2, AFNI BRIK/HEAD and Philips PAR/REC (not ECAT: nibabel's ECAT
images are read frame by frame, through another interface). Their voxels are the stored
integers where one slope and intercept scale them all (kept as ``meta['nifti_scl']``, as
for NIfTI); where the scaling varies by slice or sub-volume (MINC, PAR/REC and AFNI
may), the scaled values as float64, since no single stored dtype holds them."""

from __future__ import annotations

import json
from typing import Any

import numpy as np

from ..errors import FormatError
from ..jsonsafe import jsonable
from ..volume import Volume
from .common import (
    ReadOptions,
    check_voxels,
    header_dict,
    meta_from_json,
    native,
    origin3,
    refuse_float16,
    spacing3,
    to_volume,
)

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


_SOURCE = {  # nibabel image class -> meta['source_format'] (NIfTI and Analyze: "nifti")
    "MGHImage": "mgh",
    "Minc1Image": "minc",
    "Minc2Image": "minc",
    "AFNIImage": "afni",
    "PARRECImage": "parrec",
}


def _proxy_scaling(img) -> tuple[float, float] | None:
    """(slope, intercept) of nibabel's plain ArrayProxy (NIfTI, Analyze, MGH), read from
    the header alone; None for the other proxies (MINC, AFNI, PAR/REC), whose
    scaling may vary by slice or sub-volume (see :func:`_voxels`)."""
    obj = img.dataobj
    if not (hasattr(obj, "slope") and hasattr(obj, "inter") and hasattr(obj, "get_unscaled")):
        return None
    slope = 1.0 if obj.slope is None else float(obj.slope)
    inter = 0.0 if obj.inter is None else float(obj.inter)
    return slope, inter


def _voxels(img) -> tuple[np.ndarray, tuple[float, float] | None]:
    """The voxels as read (x fastest in nibabel's order) and the one (slope, intercept)
    that maps them to physical values, or None when they are the scaled values
    themselves (float64: the scaling varies, so no stored dtype holds them)."""
    obj = img.dataobj
    scl = _proxy_scaling(img)
    if scl is not None:
        return np.asanyarray(obj.get_unscaled()), scl
    scaled = np.asarray(obj)
    if hasattr(obj, "get_unscaled"):  # stored integers kept where one pair scales them all
        stored = np.asanyarray(obj.get_unscaled())
        for pair in _uniform_scalings(img):
            if np.array_equal(stored * pair[0] + pair[1], scaled):
                return stored, pair
    return scaled.astype(np.float64, copy=False), None


def _uniform_scalings(img) -> list[tuple[float, float]]:
    """Candidate single (slope, intercept) pairs: none at all, and PAR/REC's when every
    slice has the same (its header lists one per slice)."""
    out = [(1.0, 0.0)]
    get = getattr(img.header, "get_data_scaling", None)
    if get is not None:
        try:
            slopes, inters = (np.unique(np.asarray(v, dtype=float)) for v in get())
        except (TypeError, ValueError):
            return out
        if slopes.size == 1 and inters.size == 1:
            out.append((float(slopes[0]), float(inters[0])))
    return out


def _nifti_geometry(img, scl: tuple[float, float] | None) -> tuple[tuple, tuple, dict]:
    hdr = img.header
    zooms = list(hdr.get_zooms())
    spacing = spacing3((zooms + [1.0, 1.0, 1.0])[:3][::-1])
    affine = np.asarray(img.affine, dtype=float)
    origin = origin3(affine[:3, 3][::-1])
    meta: dict[str, Any] = {}
    for ext in getattr(hdr, "extensions", ()):
        if ext.get_code() == _NIFTI_COMMENT:
            found = meta_from_json(ext.get_content()).get("volpack_meta")
            if isinstance(found, dict):
                meta.update(found)
    source = _SOURCE.get(type(img).__name__, "nifti")
    meta.update(source_format=source, nifti_affine=jsonable(affine))
    meta.pop("nifti_scl", None)
    meta.pop("nifti_tr", None)
    if len(img.shape) >= 4 and len(zooms) >= 4 and img.shape[3] > 1:
        meta["nifti_tr"] = float(zooms[3])
    if scl is not None and scl != (1.0, 0.0):
        meta["nifti_scl"] = list(scl)
    return spacing, origin, meta


def read(path: str, opts: ReadOptions) -> Volume:
    """Stored values, never scaled: ``meta['nifti_scl'] = [slope, inter]`` says how to get
    the physical value (``stored * slope + inter``) and is written back on output."""
    img = _nifti_load(path)
    shape = _nifti_shape(img)
    check_voxels(shape, opts.max_voxels, path)
    try:
        arr, scl = _voxels(img)
    finally:  # PAR/REC images hold their .REC open (nibabel 5.x); nothing else will close it
        opened = getattr(img.dataobj, "file_like", None)
        if hasattr(opened, "close"):
            opened.close()
    spacing, origin, meta = _nifti_geometry(img, scl)
    arr = arr.reshape(shape[::-1] if len(shape) == 3 else (*shape[1:][::-1], shape[0]))
    arr = _xyz_to_zyx(arr)
    return to_volume(arr, meta, path, spacing=spacing, origin=origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    """The header alone, for nibabel's plain ArrayProxy formats (NIfTI, Analyze, MGH); the
    registry reads the others whole, since their dtype depends on the scaling found."""
    img = _nifti_load(path)
    scl = _proxy_scaling(img)
    if scl is None:
        raise FormatError(
            f"expected a NIfTI, Analyze or MGH file for a header-only read, found {path!r}"
        )
    spacing, origin, meta = _nifti_geometry(img, scl)
    dtype = native(img.get_data_dtype())
    return header_dict(meta["source_format"], _nifti_shape(img), dtype, spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
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
    refuse_float16(vol, "NIfTI")
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
