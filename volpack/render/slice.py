"""A slice drawn as the 2-D image it is, not ray cast.

A volume one voxel thick (a single CT or MRI slice, one time step of a 2-D field stored
as ``(1, y, x)``) has no depth for rays to integrate: seen at the 3-D preview's default
angles it is a dark sliver, and seen face-on its rays cross nothing at all, since the
ray caster's volume spans voxel centres. :func:`render_slice` draws the plane instead,
face-on, as an image viewer would: each pixel takes the bilinearly interpolated value
(nearest for labels), coloured by a transfer function whose opacity is scaled to its
largest, so what the TF hides stays black and what it shows most is drawn at full
strength. Every voxel covers a cell of its spacing, so a plane of one row still shows.

:func:`slice_transfer` is the automatic colouring of a slice: grey from the 0.5th to the
99.8th percentile for scans (integer data, CT, or float data with a background spike),
a blue-yellow-red map over the same window for fields (blue-grey-red, centred on zero,
for a signed field centred on zero), and the label colours of the 3-D preview for label
maps, zero black. The vertical image axis points towards increasing index (the first
row at the bottom), as the 3-D views have it, so z and y point up.
"""

from __future__ import annotations

import numpy as np

from ..errors import OptionError
from .autotf import (
    DIVERGING_COLOURS,
    FIELD_COLOURS,
    centred,
    colours,
    labels_tf,
    scan_like,
    survey,
    window,
)
from .transfer import TransferFunction, check_range

__all__ = ["render_slice", "slice_axis", "slice_transfer"]

_GREY = ((0.0, 0.0, 0.0, 0.0), (1.0, 1.0, 1.0, 1.0))
_RAMP_POINTS = 17  # points a colour ramp is written with (the ramps are piecewise linear)


def slice_axis(shape) -> int:
    """The axis a slice is drawn across: the first of length 1, else the shortest (the
    first of equals), so a stack of slices shows its middle slice."""
    shape = tuple(int(s) for s in shape)
    if len(shape) != 3:
        raise OptionError(f"slice view: expected a 3-D volume, found shape {shape}")
    ones = [k for k, s in enumerate(shape) if s == 1]
    return ones[0] if ones else int(np.argmin(shape))


def slice_transfer(values, *, dtype=None, mask=None, value_range=None) -> TransferFunction:
    """The automatic colouring of a slice (module docstring): a TransferFunction whose
    opacity is 1 wherever it shows something."""
    a = np.asarray(values)
    dtype = a.dtype if dtype is None else np.dtype(dtype)
    s, lo, hi, look = survey(a, dtype=dtype, mask=mask, value_range=value_range)
    if s.size == 0:
        return TransferFunction(((lo, 0.0, 0.0, 0.0, 0.0),), "slice-empty")
    if look == "labels":
        return labels_tf(s, lo, hi)
    if s.min() == s.max():  # one value: mid-grey, not the black of a window's low end
        return TransferFunction(((lo, 0.5, 0.5, 0.5, 1.0),), "slice-grey")
    p_lo, p_hi = window(s, lo, hi)
    if look == "ct" or scan_like(s, p_lo, p_hi, dtype):
        stops, c0, c1, name = _GREY, p_lo, p_hi, "slice-grey"
    elif centred(s, p_lo, p_hi):
        m = max(-p_lo, p_hi)
        stops, c0, c1, name = DIVERGING_COLOURS, -m, m, "slice-diverging"
    else:
        stops, c0, c1, name = FIELD_COLOURS, p_lo, p_hi, "slice-field"
    xs = np.linspace(c0, c1, _RAMP_POINTS)
    rgb = colours(stops, np.linspace(0.0, 1.0, _RAMP_POINTS))
    pts = tuple((float(x), *map(float, c), 1.0) for x, c in zip(xs, rgb))
    return TransferFunction(pts, name)


def render_slice(
    volume,
    tf: TransferFunction,
    *,
    value_range,
    size=(512, 512),
    axis: int | None = None,
    index: int | None = None,
    zoom: float = 1.0,
    nearest: bool = False,
) -> np.ndarray:
    """Draw one slice of ``volume`` face-on; return pre-multiplied ``(h, w, 4)`` float32
    RGBA on black, as :func:`volpack.render.raycast.render` does.

    Parameters
    ----------
    volume : Volume or ndarray
        A 3-D volume (a ``Volume`` brings its spacing and mask; NaN and masked voxels
        are empty).
    tf : TransferFunction
        Colours; opacity scaled to the TF's largest (module docstring).
    value_range : (lo, hi)
        The data range: the colour table spans it, and values beyond it take its ends
        (as the ray caster's tables do).
    size : (width, height)
        Image size in pixels.
    axis, index : int or None
        The slice: across ``axis`` (default :func:`slice_axis`) at ``index`` (default the
        middle).
    zoom : float
        1 fits the slice to the image along its tighter side; larger values magnify its
        centre.
    nearest : bool
        Nearest-voxel values (label maps) instead of bilinear ones.
    """
    check_range(*value_range)
    data = np.asarray(getattr(volume, "data", volume))
    if data.ndim != 3:
        raise OptionError(f"slice view: expected a 3-D volume, found shape {data.shape}")
    spacing = tuple(float(s) for s in getattr(volume, "spacing", (1.0, 1.0, 1.0)))
    mask = getattr(volume, "mask", None)
    axis = slice_axis(data.shape) if axis is None else int(axis)
    if not 0 <= axis < 3:
        raise OptionError(f"slice view: expected an axis in 0..2, found {axis}")
    n = data.shape[axis]
    index = n // 2 if index is None else int(index)
    if not 0 <= index < n:
        raise OptionError(f"slice view: expected a slice index in 0..{n - 1}, found {index}")
    w, h = (int(v) for v in size)
    if w < 1 or h < 1:
        raise OptionError(f"slice view: expected an image of at least 1x1, found {w}x{h}")
    if not zoom > 0:
        raise OptionError(f"slice view: expected a zoom > 0, found {zoom}")
    plane = np.take(data, index, axis=axis)
    bad = ~np.isfinite(plane) if plane.dtype.kind in "fc" else np.zeros(plane.shape, bool)
    if mask is not None:
        bad |= np.take(np.asarray(mask, bool), index, axis=axis)
    rows_axis, cols_axis = (k for k in range(3) if k != axis)
    values = _sample(plane, bad, spacing[rows_axis], spacing[cols_axis], w, h, zoom, nearest)
    rgba = np.zeros((h, w, 4), np.float32)
    shown = np.isfinite(values)
    peak = max(float(p[4]) for p in tf.points)
    if peak > 0 and shown.any():
        c = _colour(tf, values[shown], *value_range)
        alpha = c[:, 3] / peak
        rgba[shown, :3] = c[:, :3] * alpha[:, None]
        rgba[shown, 3] = alpha
    return rgba


_TABLE = 4096  # entries of the colour table a slice is looked up in


def _colour(tf: TransferFunction, values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """RGBA of ``values`` (clamped to ``[lo, hi]``, as the ray caster's tables are): the
    TF sampled at :data:`_TABLE` points and interpolated linearly between them, exact on
    the TF's linear pieces and within a table step of it at its knots; 3-4x faster than
    evaluating the TF per pixel."""
    lo, hi = check_range(lo, hi)
    table = tf.table(lo, hi, _TABLE)
    pos = np.clip((values - lo) * ((_TABLE - 1) / (hi - lo)), 0.0, _TABLE - 1.0)
    i0 = np.minimum(pos.astype(np.intp), _TABLE - 2)
    t = (pos - i0)[:, None]
    return table[i0] * (1.0 - t) + table[i0 + 1] * t


def _sample(plane, bad, s_rows: float, s_cols: float, w: int, h: int, zoom: float, nearest):
    """``(h, w)`` float64 values of ``plane`` at the pixel centres (NaN outside the plane
    and where the nearest voxel is empty); bilinear weights over the non-empty neighbours.
    The pixel grid maps onto the plane row by row and column by column, so every look-up
    is a gather of rows, then of columns."""
    nr, nc = plane.shape
    ext_r, ext_c = nr * s_rows, nc * s_cols
    scale = min(w / ext_c, h / ext_r) * float(zoom)  # pixels per world unit
    x = (np.arange(w) + 0.5 - w / 2.0) / scale + ext_c / 2.0
    y = (h / 2.0 - (np.arange(h) + 0.5)) / scale + ext_r / 2.0  # the first row at the bottom
    inside = ((y >= 0) & (y < ext_r))[:, None] & ((x >= 0) & (x < ext_c))[None, :]
    v = np.clip(y / s_rows - 0.5, 0.0, nr - 1.0)  # voxel coordinates, centres at integers
    u = np.clip(x / s_cols - 0.5, 0.0, nc - 1.0)
    near_r, near_c = np.rint(v).astype(np.intp), np.rint(u).astype(np.intp)
    vals = np.where(bad, 0.0, plane.astype(np.float64, copy=False))
    if nearest:
        res = vals[near_r][:, near_c]
    else:
        r0, c0 = np.floor(v).astype(np.intp), np.floor(u).astype(np.intp)
        r1, c1 = np.minimum(r0 + 1, nr - 1), np.minimum(c0 + 1, nc - 1)
        tr, tc = (v - r0)[:, None], (u - c0)[None, :]
        good = (~bad).astype(np.float64)
        num = np.zeros((h, w))
        den = np.zeros((h, w))
        for ri, wr in ((r0, 1.0 - tr), (r1, tr)):
            vrow, grow = vals[ri], good[ri]
            for ci, wc in ((c0, 1.0 - tc), (c1, tc)):
                wgt = wr * wc * grow[:, ci]
                num += wgt * vrow[:, ci]
                den += wgt
        res = num / np.where(den > 0, den, 1.0)
    empty = ~inside | bad[near_r][:, near_c]
    res[empty] = np.nan
    return res
