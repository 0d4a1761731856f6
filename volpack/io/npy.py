"""NumPy ``.npy`` files (memory-mapped) and ``.npy`` streams on standard input/output."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import FormatError
from ..format.streams import stdin
from ..volume import Volume
from .common import (
    ReadOptions,
    as_volume_array,
    check_voxels,
    header_dict,
    native,
    read_stream_into,
)


def read(path: str, opts: ReadOptions) -> Volume:
    hdr = header(path, opts)
    check_voxels(hdr["shape"], opts.max_voxels, path)
    # Memory-mapped: a large volume is paged in brick by brick as it is coded.
    arr = np.load(path, allow_pickle=False, mmap_mode="r")
    meta: dict[str, Any] = {"source_format": "npy"}
    return Volume(as_volume_array(arr, meta, path), meta=meta)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with open(path, "rb") as f:
        shape, dtype = shape_dtype(f, path)
    return header_dict("npy", shape, native(dtype), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))


def shape_dtype(f, where: str) -> tuple[tuple[int, ...], np.dtype]:
    fmt = np.lib.format
    try:
        version = fmt.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = fmt.read_array_header_1_0(f)
        else:
            shape, _, dtype = fmt.read_array_header_2_0(f)
    except ValueError as e:
        raise FormatError(f"expected a .npy header in {where}, found: {e}") from None
    return tuple(shape), dtype


def read_stdin(max_voxels: int) -> Volume:
    """A ``.npy`` stream on standard input, read into the array it declares (one copy of
    the voxels: the stream read whole, then parsed, held them twice)."""
    f = stdin()
    magic = _read_up_to(f, 6)
    if magic != b"\x93NUMPY":
        raise FormatError(
            f"expected a .npy stream on standard input, found {len(magic)} bytes starting {magic!r}"
        )
    fmt = np.lib.format
    try:
        version = tuple(_read_up_to(f, 2))
        read_header = fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
        shape, fortran, dtype = read_header(f)
    except (ValueError, IndexError) as e:
        raise FormatError(f"could not read the .npy stream on standard input: {e}") from None
    check_voxels(shape, max_voxels, "<stdin>")
    if dtype.hasobject:
        raise FormatError(f"expected numeric voxels on standard input, found dtype {dtype}")
    arr = np.empty(shape[::-1] if fortran else shape, dtype=dtype)
    read_stream_into(f, arr, "the .npy stream on standard input")
    arr = arr.T if fortran else arr
    meta: dict[str, Any] = {"source_format": "npy"}
    return Volume(as_volume_array(arr, meta, "<stdin>"), meta=meta)


def _read_up_to(f, n: int) -> bytes:
    out = b""
    while len(out) < n:
        chunk = f.read(n - len(out))
        if not chunk:
            break
        out += chunk
    return out


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_open

    with atomic_open(path, force=force) as f:
        np.save(f, vol.data, allow_pickle=False)
