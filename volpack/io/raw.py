"""Raw voxels: a layout given by options (shape, dtype, byte order, header bytes to skip)."""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import (
    ReadOptions,
    as_volume_array,
    check_voxels,
    header_dict,
    native,
    read_stream_into,
)


def _raw_dtype(dtype: Any, byteorder: str) -> np.dtype:
    if dtype is None:
        raise FormatError("expected dtype= for raw input, found none")
    order = {"little": "<", "big": ">", "native": "=", "<": "<", ">": ">", "=": "="}.get(
        str(byteorder)
    )
    if order is None:
        raise FormatError(f"expected byteorder '<' or '>', found {byteorder!r}")
    try:
        dt = np.dtype(dtype)
    except TypeError:
        raise FormatError(f"expected a numpy dtype such as uint16, found {dtype!r}") from None
    if dt.kind not in "iufb" or dt.fields is not None or dt.subdtype is not None:
        raise FormatError(f"expected an integer or float raw dtype, found {dt}")
    explicit = isinstance(dtype, str) and dtype[:1] in "<>|="
    return dt if explicit else dt.newbyteorder(order)


def _raw_shape(shape) -> tuple[int, ...]:
    if shape is None:
        raise FormatError("expected shape= Z,Y,X (slowest axis first) for raw input, found none")
    try:
        sh = tuple(int(s) for s in shape)
    except (TypeError, ValueError):
        raise FormatError(f"expected a raw shape of integers, found {shape!r}") from None
    if len(sh) not in (3, 4) or min(sh) <= 0:
        raise FormatError(
            f"expected a raw shape of 3 (z, y, x) or 4 (t, z, y, x) positive integers, "
            f"found {shape!r}"
        )
    return sh


def layout(opts: ReadOptions, size: int | None, where: str) -> tuple[tuple[int, ...], np.dtype]:
    """The checked ``(shape, dtype)`` of a raw input of ``size`` bytes (header included;
    None: a stream, whose size is checked as it is read)."""
    shape, dtype, byteorder, offset, max_voxels = opts[1:]
    sh = _raw_shape(shape)
    dt = _raw_dtype(dtype, byteorder)
    if int(offset) < 0:
        raise FormatError(f"expected a non-negative offset, found {offset}")
    check_voxels(sh, max_voxels, where)
    expected = int(offset) + math.prod(sh) * dt.itemsize
    if size is not None and size != expected:
        raise FormatError(
            f"expected {expected} bytes for shape {sh} of {dt} at offset {offset} in "
            f"{where}, found {size}"
        )
    return sh, dt


def read(path: str, opts: ReadOptions) -> Volume:
    sh, dt = layout(opts, os.path.getsize(path), path)
    offset = opts.offset
    if dt.isnative:  # memory-mapped, as for .npy
        arr = np.memmap(path, dtype=dt, mode="r", offset=int(offset), shape=sh)
    else:
        arr = np.fromfile(path, dtype=dt, count=math.prod(sh), offset=int(offset)).reshape(sh)
    meta: dict[str, Any] = {"source_format": "raw"}
    return Volume(as_volume_array(arr, meta, path), meta=meta)


def read_stdin(f, opts: ReadOptions) -> Volume:
    """Raw voxels on standard input, read into the array the options declare."""
    where = "standard input"
    sh, dt = layout(opts, None, where)
    read_stream_into(f, np.empty(int(opts.offset), np.uint8), where)  # a header to skip
    arr = np.empty(sh, dtype=dt)
    read_stream_into(f, arr, where)
    if f.read(1):
        raise FormatError(
            f"expected {arr.nbytes + int(opts.offset)} bytes for shape {sh} of {dt} at offset "
            f"{opts.offset} in {where}, found more"
        )
    meta: dict[str, Any] = {"source_format": "raw"}
    return Volume(as_volume_array(arr, meta, where), meta=meta)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    sh, dt = layout(opts, os.path.getsize(path), path)
    return header_dict("raw", sh, native(dt), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_open

    data = vol.data.astype(vol.dtype.newbyteorder("<"), copy=False)
    with atomic_open(path, force=force) as f:
        f.write(memoryview(np.ascontiguousarray(data)).cast("B"))
