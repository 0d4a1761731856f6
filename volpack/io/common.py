"""What every format module shares: options, error wrapping, the checks and conversions
a reader applies before it hands back a :class:`~volpack.volume.Volume`."""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
from collections.abc import Iterator
from typing import Any, NamedTuple

import numpy as np

from ..errors import FormatError, VolpackError
from ..jsonsafe import jsonable
from ..volume import Volume

DEFAULT_MAX_VOXELS = 1 << 34


class ReadOptions(NamedTuple):
    """What a reader may be told besides the path: the HDF5 dataset, the raw layout
    (``shape`` in ``(z, y, x)`` or ``(t, z, y, x)`` order) and the size limit."""

    inner: str | None = None
    shape: tuple[int, ...] | None = None
    dtype: Any = None
    byteorder: str = "<"
    offset: int = 0
    max_voxels: int = DEFAULT_MAX_VOXELS


@contextlib.contextmanager
def wrap_errors(fmt: str, path: str, writing: bool = False) -> Iterator[None]:
    """Turn library exceptions into one-line FormatErrors (ours pass through)."""
    try:
        yield
    except VolpackError:  # ours say what they expected already
        raise
    except FileExistsError:
        raise
    except MemoryError:
        raise
    except Exception as e:  # every library failure becomes a FormatError
        what = "write" if writing else "read"
        msg = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise FormatError(f"could not {what} {fmt} file {path!r}: {msg}") from e


def check_voxels(shape: tuple[int, ...], max_voxels: int, where: str) -> None:
    n = math.prod(int(s) for s in shape)
    if n > max_voxels:
        raise FormatError(
            f"expected at most {max_voxels} voxels, found shape {tuple(shape)} "
            f"({n} voxels) in {where}; raise max_voxels to read it"
        )


# What a user can do with the arrays volpack does not store as they are (session 32)
COMPLEX_HINT = (
    "; store the real and imaginary parts as two channels, np.stack([a.real, a.imag], -1)"
    " (a (z, y, x, 2) volume)"
)
FLAT_HINT = "; a 2-D image is a volume of one slice: a[None] (shape (1, y, x))"
LINE_HINT = "; a 1-D signal is a volume of one row: a[None, None] (shape (1, 1, x))"


def as_volume_array(arr: np.ndarray, meta: dict, where: str) -> np.ndarray:
    """Make ``arr`` 3-D or 4-D, native byte order, C-contiguous and of a supported type."""
    arr = np.asarray(arr)
    if arr.dtype.kind not in "biuf":  # bool stays bool: the codecs store it as it is
        raise FormatError(
            f"expected integer or float voxels in {where}, found dtype {arr.dtype}"
            + COMPLEX_HINT * (arr.dtype.kind == "c")
        )
    while arr.ndim > 4 and arr.shape[-1] == 1:
        arr = arr[..., 0]
    if arr.ndim not in (3, 4):
        raise FormatError(
            f"expected a 3-D (z, y, x) or 4-D (t, z, y, x) volume in {where}, "
            f"found shape {arr.shape}" + FLAT_HINT * (arr.ndim == 2) + LINE_HINT * (arr.ndim == 1)
        )
    if not arr.dtype.isnative:
        arr = arr.astype(arr.dtype.newbyteorder("="))
    return np.ascontiguousarray(arr)


def field_shape(shape, where: str, squeeze: bool = True) -> tuple[int, ...]:
    """The volume shape of an array in a container format (HDF5, netCDF, zarr): 2-D is
    one slice, 3-D (z, y, x) and 4-D (t, z, y, x) stay; with ``squeeze``, leading axes of
    length 1 (one time point, one channel) are dropped down to 3-D first."""
    found = tuple(int(s) for s in shape)
    out = found
    while squeeze and len(out) > 3 and out[0] == 1:
        out = out[1:]
    if len(out) == 2:
        out = (1, *out)
    if len(out) not in (3, 4):
        raise FormatError(
            f"expected a 2-D, 3-D (z, y, x) or 4-D (t, z, y, x) array in {where}, found "
            f"shape {found}"
        )
    return out


def spacing3(values, default: float = 1.0) -> tuple[float, float, float]:
    """Three positive finite numbers, anything else replaced by ``default``."""
    out = []
    for v in list(values)[:3]:
        try:
            f = float(v)
        except (TypeError, ValueError):
            f = default
        out.append(f if math.isfinite(f) and f > 0 else default)
    while len(out) < 3:
        out.insert(0, default)
    return tuple(out)  # type: ignore[return-value]


def origin3(values) -> tuple[float, float, float]:
    out = []
    for v in list(values)[:3]:
        try:
            f = float(v)
        except (TypeError, ValueError):
            f = 0.0
        out.append(f if math.isfinite(f) else 0.0)
    while len(out) < 3:
        out.insert(0, 0.0)
    return tuple(out)  # type: ignore[return-value]


def geometry_xyz(spacing_xyz, origin_xyz) -> tuple[tuple, tuple]:
    """``(z, y, x)`` spacing and origin from a header's x-first lists (their first three
    values; missing or unusable ones become 1 and 0)."""
    return spacing3(list(spacing_xyz)[:3][::-1]), origin3(list(origin_xyz)[:3][::-1])


def stored_meta(fields, fmt: str) -> dict[str, Any]:
    """A reader's ``meta``: what a volpack writer stored as JSON under ``volpack_meta`` in
    ``fields`` (a header or a dataset's attributes), then the ``source_format``."""
    meta: dict[str, Any] = {}
    if "volpack_meta" in fields:
        meta.update(meta_from_json(fields["volpack_meta"]))
    meta["source_format"] = fmt
    return meta


def to_volume(
    arr, meta: dict, where: str, shape=None, spacing=(1.0, 1.0, 1.0), origin=(0.0, 0.0, 0.0)
) -> Volume:
    """The Volume a reader hands back: ``arr`` (reshaped to ``shape`` when given) checked
    and converted by :func:`as_volume_array`, with its geometry and ``meta``."""
    arr = np.asarray(arr) if shape is None else np.asarray(arr).reshape(shape)
    return Volume(as_volume_array(arr, meta, where), spacing=spacing, origin=origin, meta=meta)


def header_dict(fmt, shape, dtype, spacing, origin, meta=None) -> dict[str, Any]:
    d: dict[str, Any] = {
        "format": fmt,
        "shape": [int(s) for s in shape],
        "dtype": str(np.dtype(dtype).newbyteorder("=")),
        "spacing": [float(s) for s in spacing],
        "origin": [float(o) for o in origin],
    }
    if meta:
        d["meta"] = jsonable(meta)
    return d


def native(dtype: Any) -> np.dtype:
    dt = np.dtype(dtype)
    if dt.kind == "b":
        return np.dtype(np.uint8)
    return dt.newbyteorder("=")


def prepare_for_write(vol: Volume) -> Volume:
    if vol.mask is not None and vol.dtype.kind == "f" and "special" in vol.meta:
        from ..prep import unmask_special

        vol = unmask_special(vol)
    if not vol.data.dtype.isnative or not vol.data.flags.c_contiguous:
        vol = vol.replace(data=np.ascontiguousarray(vol.data, dtype=native(vol.dtype)))
    return vol


def refuse_float16(vol: Volume, fmt: str) -> None:
    if vol.dtype == np.float16:
        raise FormatError(
            f"expected a dtype {fmt} stores (8-64 bit integers, float32, float64), found "
            f"float16; convert it first (astype='float32')"
        )


def meta_json(vol: Volume) -> str | None:
    if not vol.meta:
        return None
    return json.dumps(jsonable(vol.meta), sort_keys=True)


def meta_from_json(text: Any) -> dict:
    if isinstance(text, bytes):
        text = text.decode("utf-8", "replace")
    try:
        m = json.loads(text)
    except (TypeError, ValueError):
        return {}
    return m if isinstance(m, dict) else {}


def natural_key(name: str) -> list:
    return [int(p) if p.isdigit() else p.lower() for p in re.split(r"(\d+)", name)]


def folder_slices(path: str, exts: tuple[str, ...]) -> list[str]:
    """The names of the files in the folder ``path`` ending in one of ``exts`` (any case),
    hidden ones left out, in natural order (``s2`` before ``s10``): a folder of slices."""
    return sorted(
        (n for n in os.listdir(path) if n.lower().endswith(exts) and not n.startswith(".")),
        key=natural_key,
    )


def read_stream_into(f, arr: np.ndarray, where: str) -> None:
    """Fill ``arr`` from the binary stream ``f`` (standard input): a pipe gives what it
    has, so read until the array is full; reading the stream whole first held the voxels
    two or three times."""
    view = memoryview(arr.reshape(-1).view(np.uint8))
    got = 0
    while got < arr.nbytes:
        n = f.readinto(view[got:])
        if not n:
            raise FormatError(
                f"expected {arr.nbytes} bytes of voxels in {where}, found {got} (truncated)"
            )
        got += n
