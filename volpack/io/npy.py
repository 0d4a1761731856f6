"""NumPy ``.npy`` files (memory-mapped) and ``.npy`` streams on standard input/output."""

from __future__ import annotations

import io as _io
from typing import Any

import numpy as np

from ..errors import FormatError
from ..format.streams import stdin
from ..volume import Volume
from .common import ReadOptions, as_volume_array, check_voxels, header_dict, native


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
    blob = stdin().read()
    if not blob.startswith(b"\x93NUMPY"):
        raise FormatError(
            f"expected a .npy stream on standard input, found {len(blob)} bytes starting "
            f"{blob[:8]!r}"
        )
    buf = _io.BytesIO(blob)
    shape, _ = shape_dtype(buf, "<stdin>")
    check_voxels(shape, max_voxels, "<stdin>")
    buf.seek(0)
    try:
        arr = np.load(buf, allow_pickle=False)
    except ValueError as e:
        raise FormatError(f"could not read the .npy stream on standard input: {e}") from None
    meta: dict[str, Any] = {"source_format": "npy"}
    return Volume(as_volume_array(arr, meta, "<stdin>"), meta=meta)


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_open

    with atomic_open(path, force=force) as f:
        np.save(f, vol.data, allow_pickle=False)
