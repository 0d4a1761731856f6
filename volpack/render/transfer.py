"""Transfer functions: data value -> colour and extinction, as piecewise-linear RGBA.

A :class:`TransferFunction` is a sorted list of control points ``(value, r, g, b, a)``:

* ``value`` is in data units (Hounsfield units for CT, raw intensities otherwise);
* ``r, g, b`` in [0, 1] is the (non-associated) colour;
* ``a`` in [0, 1] is the extinction expressed as the opacity of a slab **one voxel**
  thick: the extinction coefficient per voxel length is ``tau = -ln(1 - a)``. A segment
  of ``L`` voxels of constant value therefore has opacity ``1 - (1 - a) ** L``
  (see :func:`volpack.render.preint.opacity_correct`).

Between control points every channel is linear in the value; outside the first and last
point it is constant. Equal values on two consecutive points make a step: the right-hand
point wins at the step itself.

Files are JSON::

    {"name": "bone", "space": "value" | "normalized",
     "points": [[value, r, g, b, a], ...]}

With ``"space": "normalized"`` the values lie in [0, 1] and are mapped onto the data range
``[lo, hi]`` when the file is loaded (:func:`load_tf`).

Presets (:data:`PRESETS`): ``ct-bone``, ``ct-soft``, ``mri``, ``generic``. None contains
an isosurface; isosurfaces have their own tables (:func:`volpack.render.preint.iso_table`).
The CT presets are defined in Hounsfield units and used as such when the data range looks
like CT (``lo < -500`` and ``hi > 1000``); otherwise their normalized twins are mapped
onto ``[lo, hi]``. :func:`auto_tf` picks a preset from the value range and dtype.

This module uses numpy only (no numba), so command-line parsing stays fast.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass

import numpy as np

from ..errors import FormatError

__all__ = [
    "PRESETS",
    "TransferFunction",
    "auto_tf",
    "check_range",
    "is_ct_range",
    "load_tf",
    "preset",
]

Point = tuple[float, float, float, float, float]


@dataclass(frozen=True)
class TransferFunction:
    """Piecewise-linear RGBA transfer function over data values (see module docstring).

    Attributes
    ----------
    points : tuple of (value, r, g, b, a)
        Control points, values non-decreasing, r, g, b, a in [0, 1]; ``a`` is the opacity
        of a one-voxel slab (extinction ``-ln(1 - a)`` per voxel).
    name : str
        A label carried into files and reports.
    """

    points: tuple[Point, ...]
    name: str = "custom"

    def __post_init__(self):
        pts = _check_points(self.points, f"transfer function {self.name!r}")
        object.__setattr__(self, "points", pts)
        if not isinstance(self.name, str):
            raise FormatError(f"transfer function name: expected a string, found {self.name!r}")

    # -- sampling --------------------------------------------------------------------

    def __call__(self, values) -> np.ndarray:
        """RGBA (float64, shape ``values.shape + (4,)``) at the given data values."""
        x = np.asarray(values, dtype=np.float64)
        p = np.asarray(self.points, dtype=np.float64)
        xp = p[:, 0]
        if len(xp) == 1:
            return np.broadcast_to(p[0, 1:], x.shape + (4,)).copy()
        # interval k holds xp[k] <= x < xp[k+1]; side="right" lets the later point win a step
        k = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, len(xp) - 2)
        x0, x1 = xp[k], xp[k + 1]
        width = x1 - x0
        safe = np.where(width > 0, width, 1.0)
        t = np.where(width > 0, np.clip((x - x0) / safe, 0.0, 1.0), 1.0)
        t = np.where(x < xp[0], 0.0, t)  # clamp below the first point
        t = t[..., None]
        return p[k, 1:] * (1.0 - t) + p[k + 1, 1:] * t

    def table(self, lo: float, hi: float, n: int = 256) -> np.ndarray:
        """RGBA at ``n`` values evenly spaced over ``[lo, hi]``: shape ``(n, 4)`` float32.

        Entry ``k`` is the transfer function at ``lo + k * (hi - lo) / (n - 1)``; this is
        the table that :func:`volpack.render.preint.preintegrate` takes.
        """
        lo, hi = check_range(lo, hi)
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise FormatError(f"table size: expected an integer >= 1, found {n!r}")
        xs = np.linspace(lo, hi, int(n)) if n > 1 else np.array([lo], dtype=np.float64)
        return self(xs).astype(np.float32)

    # -- files -----------------------------------------------------------------------

    def to_json(self) -> str:
        """The JSON text of this transfer function, in data-value space."""
        return json.dumps(
            {
                "name": self.name,
                "space": "value",
                "points": [[float(v) for v in p] for p in self.points],
            },
            indent=1,
        )

    @classmethod
    def from_json(cls, text, lo: float = 0.0, hi: float = 1.0) -> TransferFunction:
        """Parse JSON text (see module docstring); ``normalized`` values map onto [lo, hi].

        Raises :class:`~volpack.errors.FormatError` on anything malformed.
        """
        try:
            doc = json.loads(text)
        except (TypeError, ValueError) as e:
            raise FormatError(f"transfer function: expected JSON text, found an error: {e}") from e
        if not isinstance(doc, dict):
            raise FormatError(
                f"transfer function: expected a JSON object, found {type(doc).__name__}"
            )
        unknown = set(doc) - {"name", "space", "points"}
        if unknown:
            raise FormatError(
                f"transfer function: expected keys name, space, points; found also {sorted(unknown)}"
            )
        name = doc.get("name", "custom")
        if not isinstance(name, str):
            raise FormatError(f"transfer function name: expected a string, found {name!r}")
        space = doc.get("space", "value")
        if space not in ("value", "normalized"):
            raise FormatError(
                f"transfer function space: expected 'value' or 'normalized', found {space!r}"
            )
        if "points" not in doc:
            raise FormatError("transfer function: expected a 'points' list, found none")
        pts = _check_points(doc["points"], f"transfer function {name!r}")
        if space == "normalized":
            lo, hi = check_range(lo, hi)
            for p in pts:
                if not 0.0 <= p[0] <= 1.0:
                    raise FormatError(
                        f"transfer function {name!r}: normalized values must lie in [0, 1], "
                        f"found {p[0]}"
                    )
            pts = tuple((lo + p[0] * (hi - lo),) + p[1:] for p in pts)
        return cls(pts, name)


# -- presets ---------------------------------------------------------------------------

# The presets as data: a row per preset and scale, a point (value r g b a) between
# semicolons. ``normalized`` values span [0, 1] of the data range; a CT preset also has
# ``hounsfield`` points, used when the range looks like CT. Colours are non-associated;
# ``a`` is the opacity of one voxel, so a value of 0.1 already hides what lies 20 voxels
# behind (0.9 ** 20 = 0.12).
_PRESET_TABLE = """
ct-bone  normalized   0 0 0 0 0;  0.45 0.85 0.65 0.50 0;  0.55 0.95 0.82 0.70 0.10;  0.75 1 0.95 0.88 0.45;  1 1 1 1 0.80
ct-bone  hounsfield   -1000 0 0 0 0;  150 0.85 0.65 0.50 0;  300 0.95 0.82 0.70 0.10;  700 1 0.95 0.88 0.45;  1500 1 1 1 0.80
ct-soft  normalized   0 0 0 0 0;  0.30 0.60 0.40 0.30 0;  0.40 0.85 0.55 0.40 0.02;  0.50 0.90 0.40 0.35 0.05;  0.65 0.95 0.85 0.75 0.15;  1 1 1 1 0.40
ct-soft  hounsfield   -1000 0 0 0 0;  -200 0.60 0.40 0.30 0;  -60 0.85 0.55 0.40 0.02;  60 0.90 0.40 0.35 0.05;  300 0.95 0.85 0.75 0.15;  1000 1 1 1 0.40
mri      normalized   0 0 0 0 0;  0.10 0.10 0.10 0.10 0;  0.40 0.50 0.50 0.50 0.02;  1 1 1 1 0.10
generic  normalized   0 0.10 0.10 0.80 0;  0.25 0 0.70 0.90 0.02;  0.50 0.10 0.85 0.20 0.05;  0.75 0.95 0.90 0.10 0.10;  1 0.90 0.10 0.05 0.20
"""


def _parse_presets(text: str) -> dict[str, dict[str, tuple[Point, ...]]]:
    out: dict[str, dict[str, tuple[Point, ...]]] = {}
    for line in text.strip().splitlines():
        name, scale, points = line.split(maxsplit=2)
        rows = (tuple(float(v) for v in p.split()) for p in points.split(";"))
        out.setdefault(name, {})[scale] = tuple(rows)  # type: ignore[misc]
    return out


_PRESET_POINTS = _parse_presets(_PRESET_TABLE)

#: Names accepted by :func:`preset` and :func:`load_tf`.
PRESETS: tuple[str, ...] = tuple(_PRESET_POINTS)


def is_ct_range(lo: float, hi: float) -> bool:
    """True when ``[lo, hi]`` looks like CT in Hounsfield units: ``lo < -500 and hi > 1000``."""
    return lo < -500 and hi > 1000


def preset(name: str, lo: float, hi: float) -> TransferFunction:
    """The preset ``name`` for data in ``[lo, hi]``.

    CT presets use their Hounsfield points when :func:`is_ct_range` holds; every other
    case maps the normalized points onto ``[lo, hi]``.
    """
    if name not in _PRESET_POINTS:
        raise FormatError(f"transfer function preset: expected one of {PRESETS}, found {name!r}")
    lo, hi = check_range(lo, hi)
    points = _PRESET_POINTS[name]
    if "hounsfield" in points and is_ct_range(lo, hi):
        return TransferFunction(points["hounsfield"], name)
    normalized = points["normalized"]
    return TransferFunction(tuple((lo + p[0] * (hi - lo),) + p[1:] for p in normalized), name)


def auto_tf(lo: float, hi: float, dtype=None) -> TransferFunction:
    """Pick a preset from the data range and dtype.

    Rule, first match wins:

    1. ``lo < -500 and hi > 1000`` (CT in Hounsfield units): ``ct-bone``;
    2. an integer dtype with ``lo >= 0`` (MRI, ultrasound, 8/16-bit scans): ``mri``;
    3. anything else (float fields, signed simulation data, unknown dtype): ``generic``.
    """
    lo, hi = check_range(lo, hi)
    if is_ct_range(lo, hi):
        return preset("ct-bone", lo, hi)
    kind = np.dtype(dtype).kind if dtype is not None else "f"
    if kind in "iub" and lo >= 0:
        return preset("mri", lo, hi)
    return preset("generic", lo, hi)


def load_tf(spec: str, lo: float, hi: float, *, dtype=None) -> TransferFunction:
    """A transfer function from a preset name, ``"auto"``, or the path of a JSON file.

    ``lo, hi`` is the data range: presets and ``normalized`` files are mapped onto it.
    ``dtype`` only matters for ``"auto"`` (see :func:`auto_tf`).
    """
    if not isinstance(spec, (str, os.PathLike)):
        raise FormatError(f"transfer function: expected a preset name or a path, found {spec!r}")
    if isinstance(spec, str) and spec in _PRESET_POINTS:
        return preset(spec, lo, hi)
    if spec == "auto":
        return auto_tf(lo, hi, dtype)
    path = os.fspath(spec)
    if not os.path.isfile(path):
        raise FormatError(
            f"transfer function: expected a preset ({', '.join(PRESETS)}, auto) or a JSON "
            f"file, found {path!r} (no such file)"
        )
    try:
        with open(path, "rb") as f:
            raw = f.read((1 << 20) + 1)
    except OSError as e:
        raise FormatError(f"transfer function file {path!r}: cannot read it: {e}") from e
    if len(raw) > 1 << 20:
        raise FormatError(f"transfer function file {path!r}: expected at most 1 MiB, found more")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as e:
        raise FormatError(f"transfer function file {path!r}: expected UTF-8 JSON: {e}") from e
    try:
        return TransferFunction.from_json(text, lo, hi)
    except FormatError as e:
        raise FormatError(f"{path}: {e}") from e


# -- validation ------------------------------------------------------------------------


def nonempty_range(lo: float, hi: float) -> tuple[float, float]:
    """``(lo, hi)`` widened where needed so that ``hi - lo`` is positive: a constant
    volume, or values so large that ``lo + 1 == lo`` (a table spans ``hi - lo``)."""
    lo, hi = float(lo), float(hi)
    if hi - lo > max(1e-300, max(abs(lo), abs(hi)) * 2.0**-50):  # n / (hi - lo) is finite
        return lo, hi
    d = max(1.0, abs(lo) * 2.0**-20)
    return (lo, lo + d) if math.isfinite(lo + d) else (lo - d, lo)


def check_range(lo, hi, what: str = "data range") -> tuple[float, float]:
    """``(lo, hi)`` as finite floats with ``lo <= hi``; else a FormatError naming ``what``."""
    try:
        lo, hi = float(lo), float(hi)
    except (TypeError, ValueError) as e:
        raise FormatError(f"{what}: expected two numbers, found {lo!r}, {hi!r}") from e
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi < lo:
        raise FormatError(f"{what}: expected finite lo <= hi, found [{lo}, {hi}]")
    return lo, hi


def _check_points(points, what: str) -> tuple[Point, ...]:
    if not isinstance(points, (list, tuple)) or len(points) == 0:
        raise FormatError(f"{what}: expected a non-empty list of points, found {points!r}")
    out = []
    for i, p in enumerate(points):
        if not isinstance(p, (list, tuple, np.ndarray)) or len(p) != 5:
            raise FormatError(f"{what}: point {i}: expected [value, r, g, b, a], found {p!r}")
        try:
            q = tuple(float(v) for v in p)
        except (TypeError, ValueError) as e:
            raise FormatError(f"{what}: point {i}: expected five numbers, found {p!r}") from e
        if any(isinstance(v, (bool, np.bool_)) for v in p):
            raise FormatError(f"{what}: point {i}: expected numbers, found booleans in {p!r}")
        if not all(math.isfinite(v) for v in q):
            raise FormatError(f"{what}: point {i}: expected finite numbers, found {p!r}")
        if not all(0.0 <= v <= 1.0 for v in q[1:]):
            raise FormatError(f"{what}: point {i}: expected r, g, b, a in [0, 1], found {q[1:]}")
        if out and q[0] < out[-1][0]:
            raise FormatError(
                f"{what}: expected values in ascending order, found {q[0]} after {out[-1][0]}"
            )
        out.append(q)
    return tuple(out)
