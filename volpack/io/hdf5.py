"""HDF5 datasets through h5py: ``file.h5:/group/dataset``."""

from __future__ import annotations

import os
import shutil
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import (
    ReadOptions,
    check_voxels,
    field_shape,
    header_dict,
    meta_json,
    native,
    origin3,
    spacing3,
    stored_meta,
    to_volume,
    wrap_errors,
)

DEFAULT_DATASET = "/data"


def pick_dataset(f, inner: str | None, path: str):
    import h5py

    if inner is not None:
        if inner not in f:
            raise FormatError(f"expected a dataset {inner!r} in {path!r}, found none there")
        ds = f[inner]
        if not isinstance(ds, h5py.Dataset):
            raise FormatError(f"expected {inner!r} in {path!r} to be a dataset, found a group")
        return ds
    found = [name for name, _ in datasets(f)]
    if DEFAULT_DATASET in found:
        return f[DEFAULT_DATASET]
    if len(found) == 1:
        return f[found[0]]
    listed = ", ".join(found[:10]) or "none"
    raise FormatError(
        f"expected one dataset or {DEFAULT_DATASET!r} in {path!r} (name it as "
        f"{path}:/path), found {listed}"
    )


def datasets(f) -> list[tuple[str, Any]]:
    """``("/name", dataset)`` of every dataset of the open file ``f``, in its order."""
    import h5py

    found: list[tuple[str, Any]] = []
    f.visititems(
        lambda name, obj: found.append(("/" + name, obj)) if isinstance(obj, h5py.Dataset) else None
    )
    return found


def arrays(path: str) -> list[dict[str, Any]]:
    """Every dataset of the file: name, shape and dtype (``volpack info`` lists them when
    it cannot tell which one is meant)."""
    import h5py

    with h5py.File(path, "r") as f:
        return [
            {"name": name, "shape": list(ds.shape), "dtype": str(ds.dtype)}
            for name, ds in datasets(f)
        ]


def geometry(ds) -> tuple[tuple, tuple, dict]:
    attrs = ds.attrs
    meta = stored_meta(attrs, "hdf5")
    meta["hdf5_dataset"] = ds.name
    spacing: tuple = (1.0, 1.0, 1.0)
    for key in ("spacing", "element_size_um"):
        if key in attrs:
            spacing = spacing3(np.atleast_1d(attrs[key])[-3:])
            if key == "element_size_um":
                meta["spacing_unit"] = "um"
            break
    origin = origin3(np.atleast_1d(attrs["origin"])[-3:]) if "origin" in attrs else (0.0,) * 3
    return spacing, origin, meta


def _h5_shape(ds, path: str) -> tuple[int, ...]:
    return field_shape(ds.shape, f"the dataset {ds.name!r} of {path!r}", squeeze=False)


def read(path: str, opts: ReadOptions) -> Volume:
    inner = opts.inner
    import h5py

    with h5py.File(path, "r") as f:
        ds = pick_dataset(f, inner, path)
        shape = _h5_shape(ds, path)
        check_voxels(shape, opts.max_voxels, path)
        spacing, origin, meta = geometry(ds)
        arr = ds[()]
    return to_volume(arr, meta, path, shape, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    inner = opts.inner
    import h5py

    with wrap_errors("hdf5", path), h5py.File(path, "r") as f:
        ds = pick_dataset(f, inner, path)
        spacing, origin, meta = geometry(ds)
        if ds.dtype.kind not in "biuf":
            raise FormatError(f"expected integer or float voxels in {path!r}, found {ds.dtype}")
        return header_dict("hdf5", _h5_shape(ds, path), native(ds.dtype), spacing, origin, meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    inner = inner or DEFAULT_DATASET
    import h5py

    from ..format.atomic import atomic_path

    with (
        wrap_errors("hdf5", path, writing=True),
        atomic_path(path, force=force, suffix=".h5") as tmp,
    ):
        keep = os.path.exists(path) and h5py.is_hdf5(path)
        if keep:  # replace one dataset, keep the rest of the file
            shutil.copyfile(path, tmp)
        with h5py.File(tmp, "a" if keep else "w") as f:
            if inner in f:
                del f[inner]
            ds = f.create_dataset(inner, data=vol.data)
            ds.attrs["spacing"] = np.asarray(vol.spacing, dtype=np.float64)
            ds.attrs["origin"] = np.asarray(vol.origin, dtype=np.float64)
            text = meta_json(vol)
            if text is not None:
                ds.attrs["volpack_meta"] = text
