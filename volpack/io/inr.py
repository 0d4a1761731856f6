"""INRIMAGE-4 (``.inr``, ``.inr.gz``): a text header padded to a multiple of 256 bytes,
then the voxels, x fastest.

The header is ``#INRIMAGE-4#{`` then ``KEY=value`` lines (XDIM, YDIM, ZDIM, VDIM, TYPE,
PIXSIZE, SCALE, CPU, VX/VY/VZ for the spacing, TX/TY/TZ for the origin), newlines up to
the block size and ``##}``. The byte order comes from CPU (decm, alpha and pc are little
endian; sun and sgi big). A gzip-compressed file is read through gzip.
"""

from __future__ import annotations

import gzip
import math
from typing import Any

import numpy as np

from ..errors import FormatError
from ..volume import Volume
from .common import ReadOptions, check_voxels, geometry_xyz, header_dict, native, to_volume

_MAGIC = b"#INRIMAGE-4#{"
_END = b"##}\n"
_BLOCK = 256
_LITTLE = ("decm", "alpha", "pc")
_BIG = ("sun", "sgi")


def _open(path: str):
    with open(path, "rb") as f:
        gz = f.read(2) == b"\x1f\x8b"
    return gzip.open(path, "rb") if gz else open(path, "rb")


def _parse(f, path: str) -> dict[str, Any]:
    """Read the header from ``f`` (left at the first voxel) and return the layout."""
    head = f.read(_BLOCK)
    if not head.startswith(_MAGIC):
        raise FormatError(
            f"expected an INRIMAGE-4 header ({_MAGIC!r}) in {path!r}, found {head[:16]!r}"
        )
    while not head.rstrip(b"\n").endswith(b"##}"):
        more = f.read(_BLOCK)
        if len(more) < _BLOCK or len(head) > 64 * _BLOCK:
            raise FormatError(
                f"expected the INRIMAGE header of {path!r} to end in '##}}', found none"
            )
        head += more
    fields: dict[str, str] = {}
    for line in head.decode("latin-1").splitlines()[1:]:
        if "=" in line and not line.startswith("#"):
            key, value = line.split("=", 1)
            fields[key.strip().upper()] = value.strip()
    try:
        nx, ny, nz = (int(fields.get(k, "1")) for k in ("XDIM", "YDIM", "ZDIM"))
        nv = int(fields.get("VDIM", "1"))
    except ValueError:
        raise FormatError(
            f"expected integer XDIM/YDIM/ZDIM/VDIM in {path!r}, found {fields}"
        ) from None
    if min(nx, ny, nz) <= 0:
        raise FormatError(f"expected positive dimensions in {path!r}, found {nx} x {ny} x {nz}")
    if nv != 1:
        raise FormatError(f"expected one value per voxel (VDIM=1) in {path!r}, found VDIM={nv}")
    kind = fields.get("TYPE", "").lower()
    try:
        bits = int(fields.get("PIXSIZE", "").split()[0])
    except (IndexError, ValueError):
        raise FormatError(
            f"expected PIXSIZE=<n> bits in {path!r}, found {fields.get('PIXSIZE')!r}"
        ) from None
    code = {"unsigned fixed": "u", "signed fixed": "i", "float": "f"}.get(kind)
    if code is None or bits not in (8, 16, 32, 64) or (code == "f" and bits < 32):
        raise FormatError(
            f"expected TYPE unsigned fixed, signed fixed or float with PIXSIZE 8-64 bits in "
            f"{path!r}, found TYPE={kind!r} PIXSIZE={bits}"
        )
    cpu = fields.get("CPU", "decm").lower()
    if cpu not in _LITTLE + _BIG:
        raise FormatError(
            f"expected CPU one of {', '.join(_LITTLE + _BIG)} in {path!r}, found {cpu!r}"
        )
    order = "<" if cpu in _LITTLE else ">"
    dtype = np.dtype(f"{order}{code}{bits // 8}")
    spacing, origin = geometry_xyz(
        [fields.get(k) for k in ("VX", "VY", "VZ")], [fields.get(k, 0) for k in ("TX", "TY", "TZ")]
    )
    return {"shape": (nz, ny, nx), "dtype": dtype, "spacing": spacing, "origin": origin, "cpu": cpu}


def read(path: str, opts: ReadOptions) -> Volume:
    with _open(path) as f:
        h = _parse(f, path)
        check_voxels(h["shape"], opts.max_voxels, path)
        n = math.prod(h["shape"]) * h["dtype"].itemsize
        blob = f.read(n + 1)  # one more: trailing bytes mean the header is wrong
    if len(blob) != n:
        found = f"{len(blob)}" if len(blob) < n else "more"
        raise FormatError(
            f"expected {n} bytes of {h['dtype']} voxels for {h['shape']} after the header "
            f"of {path!r}, found {found}"
        )
    meta: dict[str, Any] = {"source_format": "inr", "inr_cpu": h["cpu"]}
    return to_volume(
        np.frombuffer(blob, h["dtype"]), meta, path, h["shape"], h["spacing"], h["origin"]
    )


def header(path: str, opts: ReadOptions) -> dict[str, Any]:
    with _open(path) as f:
        h = _parse(f, path)
    return header_dict("inr", h["shape"], native(h["dtype"]), h["spacing"], h["origin"])


def write(vol: Volume, path: str, force: bool, inner: str | None = None) -> None:
    from ..format.atomic import atomic_open

    if vol.data.ndim != 3:
        raise FormatError(f"expected a 3-D volume for an INRIMAGE file, found shape {vol.shape}")
    if vol.dtype.kind not in "iuf" or vol.dtype.itemsize < (4 if vol.dtype.kind == "f" else 1):
        raise FormatError(
            f"expected integer, float32 or float64 voxels for INRIMAGE, found {vol.dtype}"
        )
    nz, ny, nx = vol.shape
    kind = {"u": "unsigned fixed", "i": "signed fixed", "f": "float"}[vol.dtype.kind]
    lines = [
        "#INRIMAGE-4#{",
        f"XDIM={nx}",
        f"YDIM={ny}",
        f"ZDIM={nz}",
        "VDIM=1",
        f"TYPE={kind}",
        f"PIXSIZE={vol.dtype.itemsize * 8} bits",
        "SCALE=2**0",
        "CPU=decm",
        *(f"V{a}={s!r}" for a, s in zip("ZYX", vol.spacing)),
        *(f"T{a}={o!r}" for a, o in zip("ZYX", vol.origin) if o != 0.0),
    ]
    text = ("\n".join(lines) + "\n").encode("ascii")
    size = -(-(len(text) + len(_END)) // _BLOCK) * _BLOCK
    head = text + b"\n" * (size - len(text) - len(_END)) + _END
    data = memoryview(np.ascontiguousarray(vol.data, vol.dtype.newbyteorder("<"))).cast("B")
    with atomic_open(path, force=force) as f:
        if path.lower().endswith(".gz"):
            with gzip.GzipFile(fileobj=f, mode="wb", mtime=0) as gz:
                gz.write(head)
                gz.write(data)
        else:
            f.write(head)
            f.write(data)
