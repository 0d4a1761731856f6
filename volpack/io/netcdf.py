"""netCDF: ``file.nc[:VARIABLE]`` or ``file.cdf[:VARIABLE]``.

A netCDF-4 file is an HDF5 file and goes through the HDF5 reader (h5py), as it always
did; a classic file (CDF-1, the 64-bit offset CDF-2 and the 64-bit data CDF-5: most
climate archives and older model output) is read through the netCDF4 library
(``netcdf`` extra). Classic variables come back as stored: packed integers stay integers
(their ``scale_factor`` and ``add_offset`` go to ``meta``, as do ``_FillValue``,
``missing_value``, ``units`` and ``long_name``), so a lossless copy keeps every bit of the
file. ``.nc`` outputs are written by the HDF5 writer, as before.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from . import hdf5
from .common import ReadOptions, check_voxels, field_shape, header_dict, native, to_volume

HDF5_MAGIC = b"\x89HDF\r\n\x1a\n"
CLASSIC_MAGICS = (b"CDF\x01", b"CDF\x02", b"CDF\x05")  # CDF-1, CDF-2 (64-bit offsets), CDF-5
_ATTRS = (
    "units",
    "long_name",
    "standard_name",
    "scale_factor",
    "add_offset",
    "_FillValue",
    "missing_value",
    "valid_min",
    "valid_max",
)


def kind(path: str) -> str:
    """``'hdf5'`` for a netCDF-4 file, ``'classic'`` for CDF-1/2/5; anything else is an
    error naming the bytes found."""
    with open(path, "rb") as f:
        head = f.read(8)
    if head == HDF5_MAGIC:
        return "hdf5"
    if head[:4] in CLASSIC_MAGICS:
        return "classic"
    raise FormatError(
        f"expected a netCDF file (classic 'CDF' 1, 2 or 5, or netCDF-4/HDF5) in {path!r}, "
        f"found it starting with {head[:8]!r}"
    )


def _library():
    try:
        import netCDF4
    except ImportError:
        raise FormatError(
            "expected the netCDF4 library to read classic netCDF files, found it missing: "
            "pip install 'volpack[netcdf]'"
        ) from None
    return netCDF4


def _is_coordinate(name: str, var) -> bool:
    return var.dimensions == (name,)


def _pick(ds, inner: str | None, path: str):
    names = list(ds.variables)
    if inner is not None:
        name = inner.lstrip("/")
        if name not in ds.variables:
            raise FormatError(
                f"expected a variable {name!r} in {path!r}, found {', '.join(names) or 'none'}"
            )
        return name, ds.variables[name]
    fields = [
        n
        for n in names
        if not _is_coordinate(n, ds.variables[n])
        and len(ds.variables[n].shape) >= 2
        and np.dtype(ds.variables[n].dtype).kind in "biuf"
    ]
    if len(fields) == 1:
        return fields[0], ds.variables[fields[0]]
    listed = ", ".join(
        f"{n} ({'x'.join(str(s) for s in ds.variables[n].shape)})" for n in fields[:12]
    )
    raise FormatError(
        f"expected one data variable of 2 or more dimensions in {path!r} (name it as "
        f"{path}:VARIABLE), found {listed or 'none'}"
    )


def _open(path: str):
    netCDF4 = _library()
    ds = netCDF4.Dataset(path, "r")
    ds.set_auto_maskandscale(False)  # the stored values, bit for bit
    return ds


def _variable(ds, inner, path) -> tuple[str, Any, tuple[int, ...], np.dtype, dict]:
    name, var = _pick(ds, inner, path)
    dtype = np.dtype(var.dtype)
    if dtype.kind not in "biuf":
        raise FormatError(
            f"expected integer or float values in {name!r} of {path!r}, found {dtype}"
        )
    shape = field_shape(var.shape, f"the variable {name!r} {var.dimensions} of {path!r}")
    meta: dict[str, Any] = {
        "source_format": "netcdf",
        "netcdf_variable": name,
        "netcdf_dimensions": list(var.dimensions),
        "netcdf_format": ds.data_model,
    }
    attrs = {key: var.getncattr(key) for key in var.ncattrs()}
    return name, var, shape, dtype, _attributes(attrs, meta)


def _attributes(attrs, meta: dict[str, Any]) -> dict[str, Any]:
    """``meta`` with the variable attributes of :data:`_ATTRS` that ``attrs`` holds."""
    for key in _ATTRS:
        if key in attrs:
            value = np.asarray(attrs[key])
            if value.dtype.kind in "SO":  # HDF5 stores netCDF text as bytes
                value = np.asarray(np.char.decode(value.astype("S"), "utf-8", "replace"))
            meta[key] = value.item() if value.size == 1 else value.tolist()
    return meta


def _hdf5_attributes(path: str, meta: dict[str, Any]) -> dict[str, Any]:
    import h5py

    with h5py.File(path, "r") as f:
        return _attributes(f[meta["hdf5_dataset"]].attrs, meta)


def _hdf5_options(path: str, opts: ReadOptions) -> ReadOptions:
    """Name the one data variable of a netCDF-4 file when none is named: its
    coordinate variables are HDF5 dimension scales, which the HDF5 reader would count."""
    if opts.inner is not None:
        return opts
    import h5py

    with h5py.File(path, "r") as f:
        fields = [
            name
            for name, ds in hdf5.datasets(f)
            if ds.ndim >= 2 and ds.attrs.get("CLASS") != b"DIMENSION_SCALE"
        ]
    return opts._replace(inner=fields[0]) if len(fields) == 1 else opts


def arrays(path: str) -> list[dict[str, Any]]:
    """Every variable of the file: name, shape and dtype (the HDF5 datasets of a
    netCDF-4 file)."""
    if kind(path) == "hdf5":
        return hdf5.arrays(path)
    with _open(path) as ds:
        return [
            {"name": n, "shape": list(v.shape), "dtype": str(np.dtype(v.dtype))}
            for n, v in ds.variables.items()
        ]


def read(path: str, opts: ReadOptions) -> Volume:
    if kind(path) == "hdf5":
        vol = hdf5.read(path, _hdf5_options(path, opts))
        data = vol.data.reshape(field_shape(vol.data.shape, repr(path)))  # a time axis of 1 dropped
        return vol.replace(data=data, meta=_hdf5_attributes(path, dict(vol.meta)))
    with _open(path) as ds:
        _, var, shape, _, meta = _variable(ds, opts.inner, path)
        check_voxels(shape, opts.max_voxels, path)
        arr = np.asarray(var[...])
    return to_volume(arr, meta, path, shape)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    if kind(path) == "hdf5":
        head = hdf5.header(path, _hdf5_options(path, opts))
        head["meta"] = _hdf5_attributes(path, head["meta"])
        head["shape"] = list(field_shape(head["shape"], repr(path)))
        return head
    with _open(path) as ds:
        _, _, shape, dtype, meta = _variable(ds, opts.inner, path)
    return header_dict("netcdf", shape, native(dtype), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), meta)


write = hdf5.write
