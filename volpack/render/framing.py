"""Framing on what the transfer function makes visible, not on the whole grid.

A :class:`~volpack.render.camera.Camera` at ``zoom = 1`` frames the sphere around the
whole volume, so an object that fills part of the grid fills 40-50 % of the image. The
functions here return the same camera moved and zoomed so that the *visible* part fills
:data:`FILL` (80 %) of the image along its tighter side:

1. :func:`visible_cells` marks the voxels whose transfer-function opacity (one voxel
   thick) reaches a quarter of the TF's largest (:data:`SHARE_OF_PEAK`; faint voxels at
   an object's rim hardly show in the image), on a grid of at most :data:`CELLS` cells
   per axis; a cell counts when at least 1 % of its voxels do and a neighbouring cell
   counts too, so scattered noise voxels do not stretch the frame.
2. :func:`frame_volume` projects the corners of the visible cells with the camera itself
   (orthographic or perspective) and scales the zoom so that the farthest lands at FILL
   of the half image; an orthographic single view is first re-centred on the projected
   extent. For an orbit (``azimuths``) the orbit centre is the centre of the visible box
   and one zoom fits every view, so the object does not breathe as it turns.
3. :func:`fit_points` does the same for any points and framing (mesh vertices).

:func:`coverage` measures the result on an image: the bounding box of the pixels whose
opacity exceeds a threshold, as fractions of the image's width and height.

The user's zoom multiplies the fitted one, a given ``look_at`` is kept, and a camera
with an explicit ``distance`` (possibly inside the volume) is left alone.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .camera import MARGIN, Camera

__all__ = ["CELLS", "FILL", "THRESHOLD", "cell_corners", "coverage", "fit_camera", "fit_points",
           "frame_volume", "visible_cells"]  # fmt: skip

FILL = 0.8  # fraction of the image (along its tighter side) the visible part spans
THRESHOLD = 0.005  # per-voxel opacity above which a voxel may count as visible ...
SHARE_OF_PEAK = 0.25  # ... when it is also this share of the TF's largest opacity
CELLS = 48  # cells per axis of the visibility grid, at most
MIN_SHARE = 0.01  # share of a cell's voxels that must be visible for the cell to count
ZOOM_RANGE = (0.25, 16.0)  # fitted zoom kept within this


def visible_cells(values, alpha_table, lo: float, hi: float, *, mask=None, cells: int = CELLS):
    """``(visible, block)``: a boolean grid of cells of ``block`` voxels per axis where the
    transfer function shows something (module docstring, step 1).

    ``alpha_table`` is the TF opacity at ``n`` values spread evenly over ``[lo, hi]``
    (values outside clamp to its ends); non-finite voxels and ``mask`` are invisible.
    """
    a = np.asarray(values)
    alpha = np.asarray(alpha_table, np.float64)
    n = alpha.shape[0]
    block = max(1, -(-max(a.shape) // int(cells)))
    grid = tuple(-(-s // block) for s in a.shape)
    count = np.zeros(grid, np.int64)
    scale = (n - 1) / (hi - lo) if hi > lo else 0.0
    show = alpha > max(THRESHOLD, SHARE_OF_PEAK * float(alpha.max(initial=0.0)))
    lut = _value_lut(a.dtype, show, lo, scale)
    # a piece of at most CHUNK voxels (whole cells) at a time: bounded memory and no
    # float64 copy of a large volume (a 1024^3 uint8 volume took 41 s and 0.8 GB here)
    rows = block * max(1, CHUNK // (block * block * max(1, a.shape[2])))
    for z0 in range(0, a.shape[0], block):
        for y0 in range(0, a.shape[1], rows):
            part = a[z0 : z0 + block, y0 : y0 + rows]
            vis = _visible_values(part, show, lo, scale) if lut is None else lut[_as_index(part)]
            if mask is not None:
                vis &= ~np.asarray(mask[z0 : z0 + block, y0 : y0 + rows], bool)
            gy = -(-vis.shape[1] // block)
            pad = [(0, 0), (0, gy * block - vis.shape[1]), (0, grid[2] * block - vis.shape[2])]
            vis = np.pad(vis, pad)
            counts = vis.reshape(vis.shape[0], gy, block, grid[2], block).sum(axis=(0, 2, 4))
            count[z0 // block, y0 // block : y0 // block + gy] = counts
    visible = count >= np.maximum(1, MIN_SHARE * _cell_sizes(a.shape, block))
    kept = visible & (_neighbours(visible) > 0)  # a cell alone is noise
    return (kept if kept.any() else visible), block


CHUNK = 1 << 20  # voxels :func:`visible_cells` classifies at a time


def _visible_values(values, show, lo: float, scale: float) -> np.ndarray:
    """Whether each of ``values`` shows: its entry of ``show`` (``n`` entries over
    ``[lo, lo + (n - 1) / scale]``, clamped at the top; below ``lo`` and NaN: hidden)."""
    n = show.shape[0]
    v = np.asarray(values, np.float64)
    with np.errstate(invalid="ignore"):
        idx = np.clip(np.nan_to_num((v - lo) * scale, nan=-1.0), -1, n - 1)
    vis = np.where(idx >= 0, show[np.maximum(idx, 0).astype(np.int64)], False)
    vis &= np.isfinite(v)
    return vis


def _value_lut(dtype, show, lo: float, scale: float):
    """For 8- and 16-bit integers (and bools): :func:`_visible_values` of every value the
    dtype holds, indexed by :func:`_as_index`; None for other dtypes."""
    dt = np.dtype(dtype)
    if dt.kind == "b":
        dt = np.dtype(np.uint8)
    if dt.kind not in "iu" or dt.itemsize > 2:
        return None
    unsigned = np.dtype(f"u{dt.itemsize}")
    values = np.arange(1 << (8 * dt.itemsize), dtype=unsigned).view(dt.newbyteorder("="))
    return _visible_values(values, show, lo, scale)


def _as_index(part: np.ndarray) -> np.ndarray:
    """8- or 16-bit voxels as the unsigned integers that index :func:`_value_lut`."""
    if part.dtype.kind == "b":
        return part.view(np.uint8)
    if part.dtype.kind == "i" or not part.dtype.isnative:
        return part.astype(part.dtype.newbyteorder("="), copy=False).view(f"u{part.dtype.itemsize}")
    return part


def _neighbours(vis: np.ndarray) -> np.ndarray:
    """How many of each cell's 26 neighbours are set."""
    p = np.pad(vis, 1).astype(np.int8)
    z, y, x = vis.shape
    total = np.zeros(vis.shape, np.int8)
    for dz in range(3):
        for dy in range(3):
            for dx in range(3):
                if (dz, dy, dx) != (1, 1, 1):
                    total += p[dz : dz + z, dy : dy + y, dx : dx + x]
    return total


def _cell_sizes(shape, block) -> np.ndarray:
    sizes = [np.minimum(block, s - np.arange(0, s, block)) for s in shape]
    return sizes[0][:, None, None] * sizes[1][None, :, None] * sizes[2][None, None, :]


def cell_corners(visible: np.ndarray, block: int, shape, factor: int = 1, offset=(0, 0, 0)):
    """Index coordinates ``(k, 3)`` (z, y, x) of the corners of the visible cells, on the
    voxel-edge box ``[-0.5, n - 0.5]`` of the full-resolution ``shape``: the cells are
    ``block`` voxels of a grid that starts at voxel ``offset`` of a level whose voxels are
    ``factor`` full-resolution voxels per axis."""
    vis = np.asarray(visible, bool)
    used = np.zeros(tuple(g + 1 for g in vis.shape), bool)
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                used[dz : dz + vis.shape[0], dy : dy + vis.shape[1], dx : dx + vis.shape[2]] |= vis
    k = np.argwhere(used).astype(np.float64)
    full = (k * block + np.asarray(offset, np.float64)) * factor
    return np.minimum(full, np.asarray(shape, np.float64)) - 0.5


def frame_volume(
    camera: Camera,
    corners,
    shape,
    spacing=(1.0, 1.0, 1.0),
    *,
    fill: float = FILL,
    azimuths=None,
) -> Camera:
    """``camera`` re-aimed and zoomed so that the index-space points ``corners`` (the
    visible part, :func:`cell_corners`) span ``fill`` of the image (module docstring).

    ``azimuths``: the views of an orbit, all fitted with one centre and one zoom.
    """
    return fit_points(camera, corners, lambda view: view.world_frame(shape, spacing),
                      fill=fill, azimuths=azimuths)  # fmt: skip


def fit_points(camera: Camera, points, world_frame, *, fill: float = FILL, azimuths=None):
    """``camera`` aimed at the centre of the box of ``points`` (k, 3) and zoomed so that
    they span ``fill`` of the image; ``world_frame(camera)`` gives ``(camera, scale,
    centre, radius)`` as :meth:`Camera.world_frame` does (world = point times scale).
    An orthographic single view is re-centred on the points' projected extent; a given
    ``look_at`` or ``distance`` is kept (the latter: the camera comes back unchanged)."""
    pts = np.asarray(points, np.float64).reshape(-1, 3)
    if camera.distance is not None or len(pts) == 0:
        return camera
    probe = dataclasses.replace(camera, zoom=1.0)
    if camera.look_at is None:
        centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
        probe = dataclasses.replace(probe, look_at=tuple(float(v) for v in centre))
        if azimuths is None and camera.projection == "orthographic":
            probe = _recentre(probe, pts, world_frame)
    views = [probe] if azimuths is None else [
        dataclasses.replace(probe, azimuth=float(a)) for a in azimuths
    ]  # fmt: skip
    spans = []
    for view in views:
        cam, scale, centre, radius = world_frame(view)
        spans.append(_span(cam, pts * scale, centre, radius))
    return dataclasses.replace(probe, zoom=_zoom_for(max(spans), fill) * camera.zoom)


def _span(cam: Camera, world, centre, radius) -> float:
    """The largest distance of the projected points from the image centre, as a fraction
    of the half image along the same axis (1: touching the edge at zoom 1)."""
    u, v = _uv(cam, world, centre, radius)
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(v))):
        return math.inf  # a point behind a perspective eye: leave the zoom alone
    w, h = cam.size
    short = min(w, h)
    return float(max(np.abs(u).max() / (w / short), np.abs(v).max() / (h / short)))


def _uv(cam: Camera, world, centre, radius):
    """Projected points in the image's unit coordinates (the shorter half side is 1)."""
    col, row, _ = cam.project(world, centre, radius)
    w, h = cam.size
    short = min(w, h)
    return (col + 0.5) * 2 / short - w / short, h / short - (row + 0.5) * 2 / short


def _recentre(probe: Camera, pts, world_frame) -> Camera:
    """Orthographic: move the look-at point so that the projected extent is centred."""
    cam, scale, centre, radius = world_frame(probe)
    u, v = _uv(cam, pts * scale, centre, radius)
    du, dv = 0.5 * (u.max() + u.min()), 0.5 * (v.max() + v.min())
    _, right, up = cam.basis()
    half = radius * MARGIN / cam.zoom  # world units per unit of u and v
    shift = (du * right + dv * up) * half / scale
    return dataclasses.replace(probe, look_at=tuple(float(c) for c in np.add(probe.look_at, shift)))


def _zoom_for(span: float, fill: float) -> float:
    if not (math.isfinite(span) and span > 0):
        return 1.0
    return float(min(max(fill / span, ZOOM_RANGE[0]), ZOOM_RANGE[1]))


def coverage(rgba, threshold: float = 0.1) -> tuple[float, float]:
    """``(width, height)`` of the bounding box of the pixels with opacity above
    ``threshold``, as fractions of the image's width and height (0 for an empty image)."""
    a = np.asarray(rgba)[..., 3] > threshold
    if not a.any():
        return 0.0, 0.0
    rows = np.flatnonzero(a.any(axis=1))
    cols = np.flatnonzero(a.any(axis=0))
    h, w = a.shape
    return (cols[-1] - cols[0] + 1) / w, (rows[-1] - rows[0] + 1) / h


def fit_camera(
    camera: Camera,
    values,
    tf,
    lo: float,
    hi: float,
    *,
    spacing=(1.0, 1.0, 1.0),
    shape=None,
    factor: int = 1,
    mask=None,
    isos=None,
    azimuths=None,
    fill: float = FILL,
) -> Camera:
    """``camera`` framed on what ``tf`` (and the isosurfaces ``isos``) show of ``values``.

    ``values`` may be a coarse level of a larger volume of ``shape`` (full resolution),
    each of its voxels ``factor`` voxels of that volume per axis (an octree's level).
    Without anything visible the
    camera comes back unchanged.
    """
    from .transfer import nonempty_range

    a = np.asarray(values)
    shape = a.shape if shape is None else tuple(int(s) for s in shape)
    lo, hi = nonempty_range(lo, hi)
    xs = np.linspace(lo, hi, 256)
    alpha = np.zeros(256) if tf is None else _alpha_of(tf, lo, hi)
    for v, _, opacity in isos or ():
        if opacity > 0:  # an isosurface shows where the data reach its value
            alpha = np.where(xs >= v, 1.0, alpha)
    visible, block = visible_cells(a, alpha, lo, hi, mask=mask)
    if not visible.any():
        return camera
    offset = np.zeros(3, np.int64)
    if block > 1:  # look again, finer, inside the box of the visible cells
        idx = np.argwhere(visible)
        first = idx.min(axis=0) * block
        last = np.minimum((idx.max(axis=0) + 1) * block, a.shape)
        box = tuple(slice(int(f), int(e)) for f, e in zip(first, last))
        if np.prod(last - first) < 0.5 * a.size:
            fine, fblock = visible_cells(a[box], alpha, lo, hi,
                                         mask=None if mask is None else np.asarray(mask)[box])  # fmt: skip
            if fine.any():
                visible, block, offset = fine, fblock, first
    corners = cell_corners(visible, block, shape, factor, offset)
    return frame_volume(camera, corners, shape, spacing, fill=fill, azimuths=azimuths)


def _alpha_of(tf, lo: float, hi: float) -> np.ndarray:
    if hasattr(tf, "table"):
        return np.asarray(tf.table(lo, hi, 256), np.float64)[:, 3]
    tab = np.asarray(tf, np.float64)
    return np.interp(np.linspace(0, len(tab) - 1, 256), np.arange(len(tab)), tab[:, 3])
