"""VTK XML image data (``.vti``): one piece, one scalar array, read without VTK.

The array may be ``ascii``, ``binary`` (base64) or ``appended`` (raw or base64), plain or
compressed in blocks (zlib or lzma; lz4 when the ``lz4`` package is installed). Each
binary array starts with a header of ``header_type`` integers: the byte count, or for
compressed data the block count, block size, last block's size and each block's
compressed size. Point data are taken before cell data, the attribute named by
``Scalars`` before the others (the rest are named in ``meta['vti_arrays']``). Extent,
spacing and origin are x first; volpack reverses them into ``(z, y, x)``.
"""

from __future__ import annotations

import base64
import lzma
import math
import xml.etree.ElementTree as ET
import zlib
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, geometry_xyz, header_dict, native, to_volume

_TYPES = {
    "Int8": "i1",
    "UInt8": "u1",
    "Int16": "i2",
    "UInt16": "u2",
    "Int32": "i4",
    "UInt32": "u4",
    "Int64": "i8",
    "UInt64": "u8",
    "Float32": "f4",
    "Float64": "f8",
}
_NAMES = {v: k for k, v in _TYPES.items()}
_MAX_XML = 1 << 28


def _split(blob: bytes, path: str) -> tuple[ET.Element, bytes]:
    """The XML tree (without the appended block) and the appended bytes after ``_``."""
    i = blob.find(b"<AppendedData")
    appended = b""
    if i >= 0:
        start = blob.find(b"_", blob.find(b">", i)) + 1
        end = blob.rfind(b"</AppendedData>")
        appended = blob[start : end if end > start else len(blob)]
        blob = blob[:i] + b"</VTKFile>"
    try:
        root = ET.fromstring(blob)
    except ET.ParseError as e:
        raise FormatError(f"expected VTK XML in {path!r}, found: {e}") from None
    if root.tag != "VTKFile" or root.get("type") != "ImageData":
        raise FormatError(
            f"expected a VTKFile of type ImageData in {path!r}, found {root.tag} "
            f"type={root.get('type')!r}"
        )
    return root, appended


def _geometry(root: ET.Element, path: str):
    img = root.find("ImageData")
    pieces = img.findall("Piece") if img is not None else []
    if img is None or len(pieces) != 1:
        raise FormatError(f"expected one ImageData piece in {path!r}, found {len(pieces)}")
    try:
        ext = [int(v) for v in (pieces[0].get("Extent") or img.get("WholeExtent")).split()]
        sp = [float(v) for v in (img.get("Spacing") or "1 1 1").split()]
        org = [float(v) for v in (img.get("Origin") or "0 0 0").split()]
    except (AttributeError, ValueError):
        raise FormatError(f"expected numeric Extent, Spacing and Origin in {path!r}") from None
    if len(ext) != 6 or len(sp) != 3 or len(org) != 3:
        raise FormatError(f"expected a 6-number extent and 3-number spacing/origin in {path!r}")
    org = [o + e * s for o, e, s in zip(org, ext[::2], sp)]  # the first voxel's position
    points = tuple(ext[2 * a + 1] - ext[2 * a] + 1 for a in (2, 1, 0))
    return pieces[0], img, points, *geometry_xyz(sp, org)


def _pick(piece: ET.Element, points: tuple, path: str):
    """(DataArray, shape, other array names): point data first, then cell data."""
    for where, shape in (("PointData", points), ("CellData", tuple(max(n - 1, 1) for n in points))):
        node = piece.find(where)
        arrays = node.findall("DataArray") if node is not None else []
        if arrays:
            want = node.get("Scalars")
            first = next((a for a in arrays if a.get("Name") == want), arrays[0])
            others = [a.get("Name") for a in arrays if a is not first]
            return first, shape, others
    raise FormatError(f"expected a PointData or CellData array in {path!r}, found none")


def _codec(root: ET.Element, path: str):
    name = root.get("compressor")
    if not name:
        return None
    if name == "vtkZLibDataCompressor":
        return lambda b, n: zlib.decompress(b)
    if name == "vtkLZMADataCompressor":
        return lambda b, n: lzma.decompress(b)
    if name == "vtkLZ4DataCompressor":
        try:
            import lz4.block
        except ImportError:
            raise FormatError(
                f"expected the lz4 package to read {path!r} (LZ4-compressed), found it missing"
            ) from None
        return lambda b, n: lz4.block.decompress(b, uncompressed_size=n)
    raise FormatError(f"expected a zlib, lzma or lz4 compressor in {path!r}, found {name!r}")


def _decode(raw: bytes, hdt: np.dtype, codec, is_b64: bool, nbytes: int, path: str) -> bytes:
    """One binary array's bytes from its header and (compressed) blocks."""
    h = hdt.itemsize
    if is_b64:
        text = b"".join(raw.split())
        if codec is None:
            blob = base64.b64decode(text)
            return blob[h : h + int(np.frombuffer(blob[:h], hdt)[0])]
        nb = int(np.frombuffer(base64.b64decode(text[: 4 * -(-h // 3)])[:h], hdt)[0])
        hlen = 4 * -(-(3 + nb) * h // 3)
        head = np.frombuffer(base64.b64decode(text[:hlen])[: (3 + nb) * h], hdt)
        body = base64.b64decode(text[hlen:])
    else:
        if codec is None:
            return raw[h : h + int(np.frombuffer(raw[:h], hdt)[0])]
        nb = int(np.frombuffer(raw[:h], hdt)[0])
        head = np.frombuffer(raw[: (3 + nb) * h], hdt)
        body = raw[(3 + nb) * h :]
    nb, block, last = (int(v) for v in head[:3])
    sizes = [int(v) for v in head[3 : 3 + nb]]
    if sum(sizes) > len(body) or (nb - 1) * block + (last or block) != nbytes:
        raise FormatError(
            f"expected {nbytes} bytes in compressed blocks of {path!r}, found a block table "
            f"of {nb} x {block} (last {last}) over {len(body)} bytes"
        )
    out, pos = [], 0
    for i, size in enumerate(sizes):
        want = last if i == nb - 1 and last else block
        try:
            out.append(codec(body[pos : pos + size], want))
        except Exception as e:
            raise FormatError(f"could not decompress block {i} of {path!r}: {e}") from None
        pos += size
    return b"".join(out)


def _layout(path: str):
    with open(path, "rb") as f:
        blob = f.read(_MAX_XML + 1)
    if len(blob) > _MAX_XML:
        raise FormatError(
            f"expected a .vti file under {_MAX_XML} bytes, found a larger one at {path!r}"
        )
    root, appended = _split(blob, path)
    piece, img, points, spacing, origin = _geometry(root, path)
    arr, shape, others = _pick(piece, points, path)
    code = _TYPES.get(arr.get("type", ""))
    if code is None:
        raise FormatError(
            f"expected a numeric DataArray type in {path!r}, found {arr.get('type')!r}"
        )
    comps = int(arr.get("NumberOfComponents", "1"))
    if comps != 1:
        raise FormatError(
            f"expected a scalar array in {path!r}, found {comps} components in {arr.get('Name')!r}"
        )
    order = ">" if root.get("byte_order") == "BigEndian" else "<"
    return root, appended, arr, shape, np.dtype(order + code), spacing, origin, others


def read(path: str, opts: ReadOptions) -> Volume:
    root, appended, arr, shape, dtype, spacing, origin, others = _layout(path)
    check_voxels(shape, opts.max_voxels, path)
    n = math.prod(shape)
    fmt = arr.get("format", "ascii")
    if fmt == "ascii":
        data = np.array((arr.text or "").split(), dtype=dtype)
    else:
        hdt = np.dtype(
            ("<" if dtype.str[0] != ">" else ">")
            + ("u8" if root.get("header_type") == "UInt64" else "u4")
        )
        if fmt == "appended":
            enc = root.find("AppendedData")
            b64 = enc is not None and enc.get("encoding") == "base64"
            raw = appended[int(arr.get("offset", "0")) :]
            if b64:  # base64 runs to the next array's offset; the decoder stops at its header
                raw = raw.split(b"<", 1)[0]
        elif fmt == "binary":
            raw, b64 = (arr.text or "").encode("ascii"), True
        else:
            raise FormatError(
                f"expected DataArray format ascii, binary or appended in {path!r}, found {fmt!r}"
            )
        data = np.frombuffer(
            _decode(raw, hdt, _codec(root, path), b64, n * dtype.itemsize, path), dtype
        )
    if data.size != n:
        raise FormatError(
            f"expected {n} values of {dtype} for {shape} in {path!r}, found {data.size}"
        )
    meta: dict[str, Any] = {"source_format": "vti", "vti_array": arr.get("Name")}
    if others:
        meta["vti_arrays"] = others
    img = root.find("ImageData")
    direction = img.get("Direction") if img is not None else None
    if direction and [float(v) for v in direction.split()] != [1, 0, 0, 0, 1, 0, 0, 0, 1]:
        meta["vti_direction"] = [float(v) for v in direction.split()]
    return to_volume(data, meta, path, shape, spacing, origin)


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    _, _, arr, shape, dtype, spacing, origin, _ = _layout(path)
    return header_dict("vti", shape, native(dtype), spacing, origin, {"vti_array": arr.get("Name")})


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    """Point data in one zlib-compressed appended raw array (UInt64 headers, one block)."""
    from ..format.atomic import atomic_open

    if vol.data.ndim != 3:
        raise FormatError(f"expected a 3-D volume for a .vti file, found shape {vol.shape}")
    dt = vol.dtype.newbyteorder("<")
    name = _NAMES.get(dt.str[1:])
    if name is None:
        raise FormatError(
            f"expected 8-64 bit integers, float32 or float64 for .vti, found {vol.dtype}"
        )
    raw = np.ascontiguousarray(vol.data, dt).tobytes()
    packed = zlib.compress(raw, 6)
    head = np.asarray([1, len(raw), len(raw), len(packed)], "<u8").tobytes()
    nz, ny, nx = vol.shape
    xyz = lambda t: " ".join(repr(float(v)) for v in t[::-1])  # noqa: E731
    text = (
        '<?xml version="1.0"?>\n'
        '<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" '
        'header_type="UInt64" compressor="vtkZLibDataCompressor">\n'
        f'  <ImageData WholeExtent="0 {nx - 1} 0 {ny - 1} 0 {nz - 1}" Origin="{xyz(vol.origin)}" '
        f'Spacing="{xyz(vol.spacing)}" Direction="1 0 0 0 1 0 0 0 1">\n'
        f'    <Piece Extent="0 {nx - 1} 0 {ny - 1} 0 {nz - 1}">\n'
        '      <PointData Scalars="values">\n'
        f'        <DataArray type="{name}" Name="values" format="appended" offset="0"/>\n'
        "      </PointData>\n"
        "    </Piece>\n"
        "  </ImageData>\n"
        '  <AppendedData encoding="raw">\n   _'
    ).encode("ascii")
    with atomic_open(path, force=force) as f:
        f.write(text)
        f.write(head)
        f.write(packed)
        f.write(b"\n  </AppendedData>\n</VTKFile>\n")
