"""Typed reading of ``.vpk`` header fields: every value checked before it is used.

A header is JSON that passed its checksum, so any field may still hold any JSON value:
another type, an extreme number, a missing key. Each stream kind's ``check_header``
reads its fields through these functions, which return plain Python values of the
promised type and range or raise :class:`~volpack.errors.FormatError` naming the field,
what was expected and what was found.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..errors import FormatError, LimitError

# A coordinate (spacing, origin) within this magnitude keeps every product the renderer
# forms with a voxel index or a few hundred steps finite in float64 (2^62 * 1e280 << 1e308).
MAX_COORDINATE = 1e280


def field(hdr: Any, key: str, what: str = "header") -> Any:
    """``hdr[key]`` of a JSON object, or FormatError if it is not an object or lacks ``key``."""
    if not isinstance(hdr, dict):
        raise FormatError(f"expected the {what} to be a JSON object, found {_show(hdr)}")
    if key not in hdr:
        raise FormatError(f"expected {key!r} in the {what}, found keys {sorted(map(str, hdr))}")
    return hdr[key]


def integer(value: Any, name: str, lo: int, hi: int) -> int:
    """An integer (not a bool, not a float) in ``lo..hi``."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise FormatError(f"expected an integer {name}, found {_show(value)}")
    if not lo <= value <= hi:
        raise FormatError(f"expected {name} in {lo}..{hi}, found {value}")
    return int(value)


def number(
    value: Any, name: str, *, lo: float = -math.inf, hi: float = math.inf, positive: bool = False
) -> float:
    """A finite float within ``lo..hi`` (and > 0 when ``positive``)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise FormatError(f"expected a number for {name}, found {_show(value)}")
    try:
        x = float(value)
    except OverflowError:
        x = math.inf
    if not math.isfinite(x) or not lo <= x <= hi or (positive and not x > 0):
        want = "a positive finite" if positive else "a finite"
        raise FormatError(f"expected {want} {name} in [{lo:g}, {hi:g}], found {value!r}")
    return x


def optional_number(value: Any, name: str, **limits: Any) -> float | None:
    return None if value is None else number(value, name, **limits)


def text(value: Any, name: str, choices: tuple[str, ...] | None = None) -> str:
    if not isinstance(value, str):
        raise FormatError(f"expected a string for {name}, found {_show(value)}")
    if choices is not None and value not in choices:
        raise FormatError(f"expected {name} in {list(choices)}, found {value!r}")
    return value


def vector(value: Any, name: str, n: int, *, positive: bool = False) -> tuple[float, ...]:
    """``n`` finite numbers of magnitude at most :data:`MAX_COORDINATE` (spacing, origin)."""
    if not isinstance(value, (list, tuple)) or len(value) != n:
        raise FormatError(f"expected {name} as a list of {n} numbers, found {_show(value)}")
    return tuple(
        number(v, name, lo=-MAX_COORDINATE, hi=MAX_COORDINATE, positive=positive) for v in value
    )


def shape(value: Any, name: str, ndims: tuple[int, ...], max_voxels: int) -> tuple[int, ...]:
    """A shape of positive sizes whose product is within ``max_voxels``."""
    if not isinstance(value, (list, tuple)) or len(value) not in ndims:
        dims = " or ".join(map(str, ndims))
        raise FormatError(f"expected {name} as a list of {dims} sizes, found {_show(value)}")
    out = tuple(integer(v, name, 1, max_voxels) for v in value)
    if math.prod(out) > max_voxels:
        raise LimitError(f"{name} {out} exceeds the limit of {max_voxels} voxels")
    return out


def dtype(value: Any, name: str = "dtype", kinds: str = "biuf") -> np.dtype:
    """A numpy dtype of a plain numeric kind, given as its string."""
    if not isinstance(value, str):
        raise FormatError(f"expected a dtype string for {name}, found {_show(value)}")
    try:
        dt = np.dtype(value)
    except (TypeError, ValueError) as e:
        raise FormatError(f"expected a numpy dtype for {name}, found {value!r}: {e}") from None
    if dt.kind not in kinds or dt.fields is not None or dt.shape != () or dt.itemsize > 8:
        raise FormatError(f"expected a numeric {name} (kinds {kinds}), found {value!r}")
    return dt


_JSON_TYPES = {"float": (int, float), "int": (int,), "bool": (bool,), "str": (str,)}


def dataclass_config(cls: type, config: Any, what: str) -> dict:
    """A stored config of the dataclass ``cls`` (a codec, animation settings): a JSON
    object whose keys are fields and whose values have the field's annotated type
    (``float | None`` ...), floats finite. Returns it; ``cls(**config)`` may still check
    ranges."""
    if not isinstance(config, dict):
        raise FormatError(f"expected the {what} as a JSON object, found {_show(config)}")
    fields = {f.name: f.type for f in dataclasses.fields(cls)}
    for key, value in config.items():
        if key not in fields:
            raise FormatError(f"bad {what}: unknown field {key!r}")
        allowed = [t.strip() for t in str(fields[key]).split("|")]
        if value is None and "None" in allowed:
            continue
        ok = any(
            isinstance(value, _JSON_TYPES.get(t, ()))
            and (t == "bool" or not isinstance(value, bool))
            for t in allowed
        )
        if ok and isinstance(value, (int, float)) and not isinstance(value, bool):
            ok = abs(value) < 2.0**62 if isinstance(value, int) else math.isfinite(value)
        if not ok:
            raise FormatError(
                f"bad {what}: expected {key} of type {' or '.join(allowed)}, found {_show(value)}"
            )
    return config


def recorded_range(summary: Any) -> tuple[float, float] | None:
    """The summary's ``value_range`` as two finite floats ``lo <= hi``, or None when it is
    absent or not that (a summary is JSON too; the caller then measures the data)."""
    vr = summary.get("value_range") if isinstance(summary, dict) else None
    try:
        lo, hi = (number(v, "value_range") for v in vr)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        return None
    return (lo, hi) if lo <= hi else None


def raw_nbytes(hdr: dict) -> int:
    """Bytes of the decoded voxels a header describes (0 for kinds without a shape)."""
    if "shape" not in hdr:
        return 0
    n = shape(hdr["shape"], "shape", (3, 4), 1 << 62)
    return math.prod(n) * dtype(hdr.get("dtype")).itemsize


def _show(value: Any) -> str:
    s = repr(value)
    return f"{type(value).__name__} {s[:60] + '...' if len(s) > 60 else s}"
