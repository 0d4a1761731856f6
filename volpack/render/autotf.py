"""The automatic transfer function: chosen from the data's histogram, not its range alone.

:func:`auto_transfer` looks at a deterministic sample of the finite voxels (at most
:data:`SAMPLES` of them, taken on a regular stride) and picks one of three looks:

``ct`` (CT in Hounsfield units)
    At least 2 % of the voxels are air (-1100..-850 HU) and some reach bone (> 300 HU),
    with nothing below -3100 (a padding value of -3024 is allowed): the ``ct-bone``
    preset, defined in Hounsfield units.
``labels`` (a label map or a mask)
    An integer volume of at most 256 distinct values in which at least 85 % of the
    non-zero voxels equal their neighbour along x: zero is empty, every other value is
    opaque, coloured along a hue wheel by its index.
``intensity`` (scans, microscopy, simulation and climate fields)
    Otsu's threshold on a 256-bin histogram between the 0.5th and 99.8th percentiles
    splits background from object; opacity rises from zero at the threshold to its
    plateau at the 60th percentile of the object class and stays there. The plateau is
    the per-voxel opacity that hides what lies behind ``max(2, n / 48)`` voxels of object
    (``n`` the longest side of the volume), so the object reads as a shaded surface that
    its faint parts still show through. Scans (integer data, or float data with a fifth
    of the voxels in a background spike at the low end) get a bone-to-white ramp; other
    float fields a blue-yellow-red colour map over the object's values. When most voxels
    lie above the threshold the object is the low class (a vortex core of low pressure);
    a signed field centred on zero is split on ``|x|``, both tails shown.

Everything is decided from the numbers: no file names, no metadata. The result is a
plain :class:`~volpack.render.transfer.TransferFunction` whose name says the look
(``auto-ct``, ``auto-labels``, ``auto-intensity``).
"""

from __future__ import annotations

import numpy as np

from ..errors import OptionError
from .transfer import TransferFunction, check_range, load_tf, nonempty_range, preset

__all__ = ["DIVERGING_COLOURS", "FIELD_COLOURS", "SAMPLES", "auto_transfer", "centred", "classify",
           "colour_table", "colours", "labels_tf", "otsu", "sample_values", "scan_like",
           "survey", "transfer_for", "window"]  # fmt: skip

SAMPLES = 1 << 21  # voxels looked at, at most

# colour ramps: (position in [0, 1], r, g, b); FIELD_COLOURS also colours mesh surfaces
_SCAN = ((0.0, 0.62, 0.42, 0.34), (0.5, 0.90, 0.78, 0.66), (1.0, 1.00, 0.98, 0.95))
FIELD_COLOURS = (
    (0.00, 0.17, 0.32, 0.85),
    (0.35, 0.20, 0.75, 0.85),
    (0.65, 0.95, 0.85, 0.25),
    (1.00, 0.90, 0.15, 0.10),
)


def sample_values(values, mask=None, limit: int = SAMPLES) -> np.ndarray:
    """At most ``limit`` finite values (float64) of ``values`` taken on a regular stride
    (masked voxels, where ``mask`` is True, left out): the same sample on every run."""
    a = np.asarray(values)
    flat = a.reshape(-1)
    step = max(1, -(-flat.size // int(limit)))
    s = flat[::step].astype(np.float64)
    keep = np.isfinite(s)
    if mask is not None:
        keep &= ~np.asarray(mask).reshape(-1)[::step]
    return s[keep]


def otsu(samples: np.ndarray, lo: float, hi: float, bins: int = 256) -> float:
    """Otsu's threshold of ``samples`` over ``[lo, hi]``: the bin edge that maximises the
    between-class variance (the midpoint of ``[lo, hi]`` for a constant sample)."""
    lo, hi = nonempty_range(lo, hi)
    counts, edges = np.histogram(np.clip(samples, lo, hi), bins=bins, range=(lo, hi))
    p = counts.astype(np.float64)
    if p.sum() == 0:
        return 0.5 * (lo + hi)
    p /= p.sum()
    centres = 0.5 * (edges[:-1] + edges[1:])
    w0 = np.cumsum(p)
    m0 = np.cumsum(p * centres)
    mt = m0[-1]
    w1 = 1.0 - w0
    with np.errstate(divide="ignore", invalid="ignore"):
        between = (mt * w0 - m0) ** 2 / (w0 * w1)
    between[~np.isfinite(between)] = -1.0
    k = int(np.argmax(between[:-1])) if bins > 1 else 0
    return float(edges[k + 1])


def classify(samples: np.ndarray, values=None, dtype=None) -> str:
    """``"ct"``, ``"labels"`` or ``"intensity"`` (module docstring)."""
    if samples.size == 0:
        return "intensity"
    kind = np.dtype(dtype).kind if dtype is not None else "f"
    air = np.count_nonzero((samples >= -1100) & (samples <= -850)) / samples.size
    if air >= 0.02 and samples.min() >= -3100 and np.count_nonzero(samples > 300) > 0:
        return "ct"
    if kind in "iub" and values is not None and _looks_like_labels(np.asarray(values), samples):
        return "labels"
    return "intensity"


def _looks_like_labels(values: np.ndarray, samples: np.ndarray) -> bool:
    if np.unique(samples).size > 256 or values.ndim < 1 or values.shape[-1] < 2:
        return False
    # rows along x on a stride, as the sample: labels repeat, intensities vary
    rows = values.reshape(-1, values.shape[-1])
    rows = rows[:: max(1, -(-rows.shape[0] // 4096))]
    left, right = rows[:, :-1], rows[:, 1:]
    nonzero = (left != 0) | (right != 0)
    n = np.count_nonzero(nonzero)
    return n > 0 and np.count_nonzero((left == right) & nonzero) >= 0.85 * n


def plateau(n: int) -> float:
    """Per-voxel opacity that hides 95 % behind ``max(2, n / 48)`` voxels."""
    depth = max(2.0, n / 48.0)
    return float(1.0 - 0.05 ** (1.0 / depth))


def auto_transfer(values, *, dtype=None, mask=None, value_range=None, size=None):
    """The automatic transfer function of ``values`` (module docstring).

    Parameters
    ----------
    values : array_like
        The voxels (any shape; a 3-D volume for the label test), or a sample of them.
    dtype : numpy dtype
        The data's stored type (default ``values.dtype``): integer data may be labels.
    mask : bool array or None
        True where a voxel is missing (left out).
    value_range : (lo, hi) or None
        The range the TF table will span (default the sample's range); the TF's points
        stay inside it.
    size : int or None
        Longest side of the volume in voxels (default the longest axis of ``values``).
    """
    a = np.asarray(values)
    dtype = a.dtype if dtype is None else np.dtype(dtype)
    s, lo, hi, look = survey(a, dtype=dtype, mask=mask, value_range=value_range)
    n = int(size) if size is not None else (max(a.shape) if a.ndim else 1)
    if look == "ct":
        tf = preset("ct-bone", -1024.0, 3071.0)
        return TransferFunction(tf.points, "auto-ct")
    if look == "labels":
        return labels_tf(s, lo, hi)
    return _intensity_tf(s, lo, hi, dtype, n)


def survey(values, *, dtype=None, mask=None, value_range=None):
    """``(sample, lo, hi, look)``: :func:`sample_values` of ``values``, the range (the
    sample's unless ``value_range`` is given, never empty) and :func:`classify`'s look."""
    a = np.asarray(values)
    dtype = a.dtype if dtype is None else np.dtype(dtype)
    s = sample_values(a, mask)
    if value_range is None:
        lo, hi = (float(s.min()), float(s.max())) if s.size else (0.0, 1.0)
    else:
        lo, hi = check_range(*value_range)
    lo, hi = nonempty_range(lo, hi)
    return s, lo, hi, classify(s, a if a.ndim == 3 else None, dtype)


def labels_tf(s: np.ndarray, lo: float, hi: float) -> TransferFunction:
    """Zero empty, every label opaque; hues stride across the labels so that neighbouring
    labels differ in colour (12 hues, stepping 5 of 12 round the wheel)."""
    top = max(float(s.max()), 1.0)
    k, a = 12, 0.6
    pts = [(min(lo, 0.0), *_hue(0.0), 0.0)]
    pts += [(0.5 + (top - 0.5) * i / k, *_hue((i * 5 % k) / k), a) for i in range(k + 1)]
    return TransferFunction(tuple(pts), "auto-labels")


def _hue(h: float) -> tuple[float, float, float]:
    import colorsys

    return colorsys.hsv_to_rgb(h, 0.7, 0.95)


def _intensity_tf(s, lo, hi, dtype, n) -> TransferFunction:
    """Otsu's split; the object is the smaller class (high values, or low ones when most
    voxels lie above the threshold); a signed field centred on zero is split on ``|x|``
    so that both tails show, blue below zero and red above."""
    if s.size == 0:
        return TransferFunction(((lo, 0.8, 0.8, 0.8, 0.0),), "auto-intensity")
    if s[0] == s.min() == s.max():  # one value: no split to make; show the block it fills
        return TransferFunction(((lo, 0.8, 0.8, 0.8, plateau(n)),), "auto-intensity")
    p_lo, p_hi = window(s, lo, hi)
    amax = plateau(n)
    knots = [lo, hi, 0.0]
    if centred(s, p_lo, p_hi):
        m = max(-p_lo, p_hi)
        mag = np.abs(s)
        t = otsu(mag, 0.0, m)
        top = _deeper(mag[mag > t], 60, t, m)

        def alpha(x):
            return amax * np.clip((np.abs(x) - t) / (top - t), 0.0, 1.0)

        def colour(x):
            return colours(DIVERGING_COLOURS, (np.asarray(x) + m) / (2 * m))

        knots += [-m, -top, -t, t, top, m]
    else:
        t = otsu(s, p_lo, p_hi)
        if np.count_nonzero(s > t) <= 0.5 * s.size:  # the object is above the threshold
            top = _deeper(s[s > t], 60, t, p_hi)
            c0, c1 = t, max(p_hi, top)
        else:  # most voxels above: the object is the low class
            top = _deeper(s[s <= t], 40, t, p_lo)
            c0, c1 = min(p_lo, top), t
        # a scan (integers, or a fifth of the voxels in one background spike at the low
        # end, as a float CT or MRI) in bone-to-white; other fields in a colour map
        stops = _SCAN if scan_like(s, p_lo, p_hi, dtype) else FIELD_COLOURS

        def alpha(x):
            return amax * np.clip((np.asarray(x) - t) / (top - t), 0.0, 1.0)

        def colour(x):
            return colours(stops, (np.asarray(x) - c0) / (c1 - c0))

        knots += [t, top, c0, c1] + [c0 + (c1 - c0) * p[0] for p in stops]
    xs = np.unique(np.clip(np.asarray(knots, np.float64), lo, hi))
    rgb = colour(xs)
    a = alpha(xs)
    pts = tuple((float(x), *map(float, c), float(v)) for x, c, v in zip(xs, rgb, a))
    return TransferFunction(pts, "auto-intensity")


def window(s: np.ndarray, lo: float, hi: float) -> tuple[float, float]:
    """The 0.5th and 99.8th percentiles of the sample ``s``, inside ``[lo, hi]`` and apart."""
    p_lo, p_hi = (float(v) for v in np.percentile(s, [0.5, 99.8]))
    return nonempty_range(max(p_lo, lo), min(max(p_hi, p_lo), hi))


def centred(s: np.ndarray, p_lo: float, p_hi: float) -> bool:
    """A signed field centred on zero: its window spans zero and its median is near it."""
    return p_lo < 0 < p_hi and abs(float(np.median(s))) < 0.05 * (p_hi - p_lo)


def scan_like(s: np.ndarray, p_lo: float, p_hi: float, dtype) -> bool:
    """A scan: integer data, or a fifth of the voxels in one background spike at the low
    end of the window (a float CT or MRI)."""
    spike = np.count_nonzero(s <= p_lo + 0.02 * (p_hi - p_lo)) >= 0.2 * s.size
    return np.dtype(dtype).kind in "iub" or spike


def _deeper(obj: np.ndarray, q: float, t: float, end: float) -> float:
    """The ``q``-th percentile of the object class ``obj``: where the opacity ramp from
    ``t`` reaches its plateau (towards ``end`` when the class is empty or flat)."""
    top = float(np.percentile(obj, q)) if obj.size else end
    if top == t:
        top = t + 0.5 * (end - t) if end != t else t + max(abs(t), 1.0) * 1e-3
    return top


DIVERGING_COLOURS = ((0.0, 0.15, 0.35, 0.95), (0.5, 0.85, 0.85, 0.85), (1.0, 0.95, 0.20, 0.10))


def colours(stops, pos) -> np.ndarray:
    """``(k, 3)`` colours of the ramp ``stops`` at positions ``pos`` (clamped to [0, 1])."""
    pos = np.clip(np.atleast_1d(np.asarray(pos, np.float64)), 0.0, 1.0)
    xs = [p[0] for p in stops]
    return np.stack([np.interp(pos, xs, [p[c] for p in stops]) for c in (1, 2, 3)], axis=1)


def colour_table(n: int = 256, stops=FIELD_COLOURS) -> np.ndarray:
    """``(n, 3)`` colours of the ramp ``stops`` at ``n`` evenly spaced positions."""
    return colours(stops, np.linspace(0.0, 1.0, n))


def transfer_for(spec, values, *, lo: float, hi: float, dtype=None, mask=None, size=None):
    """The transfer function a command draws with: ``spec`` None or ``"auto"`` gives
    :func:`auto_transfer` of ``values``; anything else is :func:`load_tf`'s (a preset name
    or a JSON file)."""
    if spec is None or spec == "auto":
        if values is None:
            raise OptionError("tf: expected data to choose the automatic transfer function from")
        return auto_transfer(values, dtype=dtype, mask=mask, value_range=(lo, hi), size=size)
    return load_tf(spec, lo, hi, dtype=dtype)
