"""The in-memory volume: a voxel array with its geometry and how its values were made.

Axis order is ``(z, y, x)``, with time leading for animations ``(t, z, y, x)``;
``spacing`` and ``origin`` follow the same order (spatial axes only).
"""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import Any

import numpy as np

from .errors import FormatError

log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True, eq=False)
class Volume:
    """A regular 3-D grid, or a sequence of them along a leading time axis.

    Parameters
    ----------
    data : ndarray
        ``(z, y, x)`` or ``(t, z, y, x)`` voxels, any integer or float dtype.
    spacing : tuple of float
        Voxel size along ``(z, y, x)``; 1.0 each when unknown.
    origin : tuple of float
        Position of voxel ``(0, 0, 0)`` along ``(z, y, x)``.
    mask : ndarray of bool, optional
        Same shape as ``data``; True marks voxels whose stored value is not a measurement
        (NaN, Inf or a fill value). Their original values live in ``meta['special']``.
    meta : dict
        Provenance that must travel with the data, e.g. the quantisation record written
        by :func:`volpack.prep.quantize` (scale, offset, max error).
    """

    data: np.ndarray
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    mask: np.ndarray | None = None
    meta: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self) -> None:
        data = self.data
        if not isinstance(data, np.ndarray):
            data = np.asarray(data)
            object.__setattr__(self, "data", data)
        if data.ndim not in (3, 4):
            raise FormatError(
                f"expected a volume with 3 axes (z, y, x) or 4 axes (t, z, y, x), "
                f"found an array of shape {data.shape}"
            )
        if data.dtype.kind not in "biuf":
            raise FormatError(f"expected integer or float voxels, found dtype {data.dtype}")
        object.__setattr__(self, "spacing", _triple(self.spacing, "spacing", positive=True))
        object.__setattr__(self, "origin", _triple(self.origin, "origin"))
        if self.mask is not None:
            m = np.asarray(self.mask, dtype=bool)
            if m.shape != data.shape:
                raise FormatError(f"mask shape {m.shape} does not match data shape {data.shape}")
            object.__setattr__(self, "mask", m)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.data.shape

    @property
    def dtype(self) -> np.dtype:
        return self.data.dtype

    @property
    def is_animation(self) -> bool:
        return self.data.ndim == 4

    @property
    def nbytes(self) -> int:
        return int(self.data.nbytes)

    def replace(self, **changes: Any) -> Volume:
        """Return a copy with some fields replaced (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def describe(self) -> dict[str, Any]:
        """Return shape, dtype, spacing, value range and size as plain JSON types."""
        d = self.data
        valid = d if self.mask is None else d[~self.mask]
        if d.dtype.kind == "f":
            valid = valid[np.isfinite(valid)]
        lo = hi = None
        if valid.size:
            lo, hi = valid.min().item(), valid.max().item()
        out: dict[str, Any] = {
            "shape": list(d.shape),
            "dtype": str(d.dtype),
            "spacing": list(self.spacing),
            "origin": list(self.origin),
            "min": lo,
            "max": hi,
            "nbytes": int(d.nbytes),
        }
        if d.dtype.kind == "f":
            out["nan"] = int(np.isnan(d).sum())
            out["inf"] = int(np.isinf(d).sum())
        if self.mask is not None:
            out["masked"] = int(self.mask.sum())
        if self.meta:
            out["meta"] = self.meta
        return out


def declared_fill(vol: Volume) -> float | None:
    """The no-data value the source file declares for float voxels (netCDF's
    ``_FillValue``, else ``missing_value``), so that a lossy bound, and a bound relative
    to the value range, apply to the data and not to the fill, and a render leaves it
    empty; None when there is none."""
    return fill_in_meta(vol.meta, vol.dtype)


def fill_in_meta(meta: dict | None, dtype) -> float | None:
    """:func:`declared_fill` of a volume's ``meta`` and ``dtype`` (a header, before or
    without reading the voxels)."""
    if np.dtype(dtype).kind != "f" or not isinstance(meta, dict):
        return None
    for key in ("_FillValue", "missing_value"):
        value = meta.get(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            log.info("%s %r of the source taken as the fill value", key, value)
            return float(value)
    return None


def with_fill_masked(vol: Volume) -> Volume:
    """``vol`` with the voxels equal to its declared fill value (:func:`declared_fill`)
    added to its mask, so that a render leaves them empty as it does NaN and masked voxels;
    ``vol`` itself when it declares none or holds none."""
    fill = declared_fill(vol)
    if fill is None:
        return vol
    hit = vol.data == vol.data.dtype.type(fill)
    if not hit.any():
        return vol
    mask = hit if vol.mask is None else (hit | np.asarray(vol.mask, bool))
    return dataclasses.replace(vol, mask=mask)


def require_voxels(shape: tuple[int, ...]) -> None:
    """Refuse a shape with an axis of length 0: there is nothing to code, and the
    codecs' value ranges and brick grids need at least one voxel."""
    if 0 in tuple(shape):
        raise FormatError(f"expected a volume with at least one voxel, found shape {tuple(shape)}")


def _triple(value: Any, name: str, positive: bool = False) -> tuple[float, float, float]:
    try:
        t = tuple(float(v) for v in value)
    except TypeError:
        raise FormatError(f"expected {name} as three numbers (z, y, x), found {value!r}") from None
    if len(t) != 3 or not all(map(math.isfinite, t)):  # (np.isfinite: 1 us a call)
        raise FormatError(f"expected {name} as three finite numbers (z, y, x), found {value!r}")
    if positive and min(t) <= 0:
        raise FormatError(f"expected positive {name}, found {value!r}")
    return t  # type: ignore[return-value]
