"""MetaImage (ITK, 3D Slicer): ``.mha`` (header and voxels in one file) or ``.mhd`` (a
text header naming a separate data file).

The header is ``Key = Value`` lines; ``ElementDataFile`` is the last and says where the
voxels are (``LOCAL``: right after it). Sizes and spacings are listed x first, so they
are reversed here into volpack's ``(z, y, x)``. ``CompressedData = True`` means one zlib
stream. A data file given as a list or a slice pattern is refused with a message.
"""

from __future__ import annotations

import math
import os
import zlib
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, geometry_xyz, header_dict, native, to_volume

_TYPES = {
    "MET_CHAR": "i1",
    "MET_UCHAR": "u1",
    "MET_SHORT": "i2",
    "MET_USHORT": "u2",
    "MET_INT": "i4",
    "MET_UINT": "u4",
    "MET_LONG": "i4",
    "MET_ULONG": "u4",
    "MET_LONG_LONG": "i8",
    "MET_ULONG_LONG": "u8",
    "MET_FLOAT": "f4",
    "MET_DOUBLE": "f8",
}
_CODES = {"i1": "MET_CHAR", "u1": "MET_UCHAR", "i2": "MET_SHORT", "u2": "MET_USHORT",
          "i4": "MET_INT", "u4": "MET_UINT", "i8": "MET_LONG_LONG", "u8": "MET_ULONG_LONG",
          "f4": "MET_FLOAT", "f8": "MET_DOUBLE"}  # fmt: skip
_MAX_HEADER = 1 << 16


def _true(value: str | None) -> bool:
    return str(value).strip().lower() in ("true", "1", "yes")


def _parse(path: str) -> dict[str, Any]:
    """The header's fields, the layout, and where the voxels start."""
    fields: dict[str, str] = {}
    with open(path, "rb") as f:
        while True:
            line = f.readline(4096)
            if not line or f.tell() > _MAX_HEADER:
                raise FormatError(
                    f"expected a MetaImage header ending in 'ElementDataFile = ...' in {path!r}, "
                    f"found {'end of file' if not line else 'more than 64 KB of header'}"
                )
            text = line.decode("latin-1").strip()
            if not text or text.startswith("#"):
                continue
            if "=" not in text:
                raise FormatError(f"expected 'Key = Value' lines in {path!r}, found {text[:60]!r}")
            key, value = (s.strip() for s in text.split("=", 1))
            fields[key] = value
            if key == "ElementDataFile":
                data_start = f.tell()
                break
    try:
        ndims = int(fields.get("NDims", "3"))
        dims = [int(v) for v in fields["DimSize"].split()]
    except (KeyError, ValueError):
        raise FormatError(f"expected NDims and DimSize in {path!r}, found {fields}") from None
    if ndims not in (2, 3, 4) or len(dims) != ndims or min(dims) <= 0:
        raise FormatError(
            f"expected a 3-D or 4-D MetaImage with positive DimSize in {path!r}, found NDims "
            f"{ndims}, DimSize {dims}"
        )
    channels = int(fields.get("ElementNumberOfChannels", "1"))
    if channels != 1:
        raise FormatError(f"expected one channel per voxel in {path!r}, found {channels}")
    code = _TYPES.get(fields.get("ElementType", ""))
    if code is None:
        raise FormatError(
            f"expected an ElementType among {', '.join(_TYPES)} in {path!r}, found "
            f"{fields.get('ElementType')!r}"
        )
    msb = _true(fields.get("BinaryDataByteOrderMSB", fields.get("ElementByteOrderMSB")))
    shape = tuple(dims[::-1]) if ndims > 2 else (1, *dims[::-1])
    spacing_xyz = (fields.get("ElementSpacing") or fields.get("ElementSize") or "").split()
    origin_xyz = (
        fields.get("Offset") or fields.get("Origin") or fields.get("Position") or ""
    ).split()
    spacing, origin = geometry_xyz(spacing_xyz, origin_xyz)
    return {
        "fields": fields,
        "shape": shape,
        "dtype": np.dtype((">" if msb else "<") + code),
        "spacing": spacing,
        "origin": origin,
        "data_start": data_start,
    }


def _data_location(h: dict[str, Any], path: str) -> tuple[str, int | None]:
    """(file, offset) of the voxels; offset None means 'the last bytes of the file'."""
    name = h["fields"]["ElementDataFile"]
    if name == "LOCAL":
        return path, h["data_start"]
    if name.split()[0] == "LIST" or len(name.split()) > 1 or "%" in name:
        raise FormatError(
            f"expected ElementDataFile LOCAL or one file in {path!r}, found {name!r} (slice "
            f"lists and patterns are not read)"
        )
    data = os.path.join(os.path.dirname(os.path.abspath(path)), name)
    if not os.path.isfile(data):
        raise FormatError(f"expected the data file {data!r} named in {path!r}, found nothing")
    skip = int(h["fields"].get("HeaderSize", "0"))
    return data, None if skip == -1 else skip


def read(path: str, opts: ReadOptions) -> Volume:
    h = _parse(path)
    check_voxels(h["shape"], opts.max_voxels, path)
    n = math.prod(h["shape"]) * h["dtype"].itemsize
    data, offset = _data_location(h, path)
    compressed = _true(h["fields"].get("CompressedData"))
    with open(data, "rb") as f:
        if offset is None:
            f.seek(0, os.SEEK_END)
            offset = f.tell() - n
        f.seek(offset)
        blob = f.read() if compressed else f.read(n)
    if compressed:
        try:
            blob = zlib.decompressobj().decompress(blob, n)
        except zlib.error as e:
            raise FormatError(f"expected zlib-compressed voxels in {data!r}, found: {e}") from None
    if len(blob) != n:
        raise FormatError(
            f"expected {n} bytes of {h['dtype']} voxels for {h['shape']} in {data!r}, found {len(blob)}"
        )
    meta: dict[str, Any] = {"source_format": "metaimage"}
    matrix = h["fields"].get("TransformMatrix")
    if matrix and [float(v) for v in matrix.split()] != [1, 0, 0, 0, 1, 0, 0, 0, 1]:
        meta["metaimage_transform"] = [float(v) for v in matrix.split()]
    return to_volume(
        np.frombuffer(blob, h["dtype"]), meta, path, h["shape"], h["spacing"], h["origin"]
    )


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    h = _parse(path)
    return header_dict("metaimage", h["shape"], native(h["dtype"]), h["spacing"], h["origin"])


def data_file(path: str) -> str:
    """The data file a ``.mhd`` header ``path`` is written with: ``<name>.raw`` beside it."""
    return os.path.join(os.path.dirname(path), os.path.splitext(os.path.basename(path))[0] + ".raw")


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    """``.mha``: one file; ``.mhd``: the header plus ``<name>.raw`` beside it."""
    from ..format.atomic import atomic_open

    code = _CODES.get(vol.dtype.str[1:])
    if code is None:
        raise FormatError(
            f"expected 8-64 bit integers, float32 or float64 for MetaImage, found {vol.dtype}"
        )
    nd = vol.data.ndim
    local = path.lower().endswith(".mha")
    raw_name = os.path.basename(data_file(path))
    rev = lambda t: " ".join(repr(float(v)) for v in t[::-1])  # noqa: E731
    lines = [
        "ObjectType = Image",
        f"NDims = {nd}",
        "BinaryData = True",
        "BinaryDataByteOrderMSB = False",
        "CompressedData = False",
        "TransformMatrix = "
        + " ".join(["1 0 0 0 1 0 0 0 1", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1"][nd - 3]),
        "Offset = " + rev(vol.origin) + (" 0" if nd == 4 else ""),
        "ElementSpacing = " + rev(vol.spacing) + (" 1" if nd == 4 else ""),
        "DimSize = " + " ".join(str(n) for n in vol.shape[::-1]),
        f"ElementType = {code}",
        f"ElementDataFile = {'LOCAL' if local else raw_name}",
    ]
    head = ("\n".join(lines) + "\n").encode("ascii")
    data = memoryview(np.ascontiguousarray(vol.data, vol.dtype.newbyteorder("<"))).cast("B")
    if not local:  # the data file first, so a header never names a missing file
        with atomic_open(data_file(path), force=force) as f:
            f.write(data)
    with atomic_open(path, force=force) as f:
        f.write(head)
        if local:
            f.write(data)
