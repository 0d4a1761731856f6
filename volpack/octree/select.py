"""Level-of-detail selection: which octree nodes to decode for a request.

A selection is a list of ``(level, (bz, by, bx))`` nodes whose footprints do not
overlap and together cover the requested region; :meth:`Octree.assemble
<volpack.octree.reader.Octree.assemble>` turns it into one array, and a renderer draws
its nodes as bricks (:meth:`Octree.brick <volpack.octree.reader.Octree.brick>`). Every
choice reads only the node tables (no chunk is decoded):

* :func:`by_level` - every node of one level;
* :func:`by_error` - the coarsest nodes whose largest deviation is within a bound;
* :func:`by_budget` - greedy refinement of the node with the largest error ``E`` (or, with
  a camera, ``E / z``: seed-004 §7.4) until a voxel or byte budget is spent;
* :func:`by_view` - the view-dependent choice: frustum culling, transparent-node
  skipping under a transfer function, the projective stop (a node whose voxels project
  to at most one pixel is not refined, §7.3), and the transfer-function-aware screen-space
  error of eqs. 2.5-2.7 (§7.5) as the priority and the stopping threshold.
"""

from __future__ import annotations

import heapq
import itertools
import math
from typing import Any

import numpy as np

from ..errors import FormatError, OptionError
from . import layout
from .reader import Octree, parse_region

Node = tuple[int, tuple[int, int, int]]


def by_level(tree: Octree, level: int, roi=None) -> list[Node]:
    """Every node of ``level`` that meets ``roi`` (full-resolution region)."""
    level = tree.geometry.check_level(level)
    region = parse_region(roi, tree.shape)
    return [(level, b) for b in _nodes_in(tree, level, region)]


def by_error(tree: Octree, bound: float, roi=None) -> list[Node]:
    """The coarsest nodes whose largest deviation from the input (``maxdev``) is at most
    ``bound``; refining down to level 0 where nothing coarser qualifies."""
    if not bound >= 0:
        raise OptionError(f"expected an error bound >= 0, found {bound!r}")
    finest = tree.max_error
    if bound < finest:
        raise OptionError(
            f"expected an error bound of at least {finest:g} (the full-resolution level of "
            f"this lossy file is only within that), found {bound:g}"
        )
    region = parse_region(roi, tree.shape)
    out: list[Node] = []
    stack = [(tree.depth, (0, 0, 0))]
    while stack:
        lv, b = stack.pop()
        if lv == 0 or float(tree.row(lv, b)["maxdev"]) <= bound:
            out.append((lv, b))
            continue
        stack.extend(c for c in reversed(children(tree, lv, b, region)))
    return sorted(out)


def by_budget(
    tree: Octree,
    *,
    voxels: int | None = None,
    nbytes: int | None = None,
    roi=None,
    camera: Any = None,
) -> list[Node]:
    """Refine greedily, largest priority first, while the budget allows.

    The priority of a node is its subtree error ``E`` (seed-004 §7.4), divided by its
    nearest distance to the eye when a ``camera`` is given. ``voxels`` caps the voxels of
    the selected nodes (the renderer's texture memory), ``nbytes`` the chunk bytes read.
    """
    view = _View(tree, camera) if camera is not None else None

    def priority(lv, b):
        e = float(tree.row(lv, b)["E"]) if lv > 0 else 0.0
        if view is None:
            return e
        z = view.depth(tree, lv, b)
        return math.inf if z <= 0 and e > 0 else e / max(z, 1e-12)

    return _refine(tree, priority, voxels, nbytes, roi, view)


def by_view(
    tree: Octree,
    camera: Any,
    *,
    tf: Any = None,
    voxels: int | None = None,
    max_pixel_error: float = 1.0 / 128,
    roi=None,
    memo: dict | None = None,
) -> tuple[list[Node], dict[str, Any]]:
    """The view-dependent selection a renderer uses (seed-004 §7.3-§7.6).

    Nodes outside the camera's frustum are dropped; with a transfer function ``tf``
    (:class:`~volpack.render.transfer.TransferFunction`), so are nodes that are fully
    transparent over their whole value range. Refinement takes the node with the largest
    screen-space error first: ``E / z`` without ``tf``; with ``tf``, the bound of eq.
    2.7 on the colour and opacity error of a ray through the node, from its deviation
    histogram, times the node's projected area in pixels. A node is not refined when its
    voxels project to at most one pixel, when its error is below ``max_pixel_error``
    (per pixel of its area; the thesis's high quality is 1/128), or when the ``voxels``
    budget would be exceeded.

    ``memo``, a dict kept across the frames of a walk, holds what does not depend on the
    view (each node's TF error and transparency, per transfer function): most of a
    selection's time otherwise.

    Returns the selection and counts (culled, transparent, stopped by projection).
    """
    view = _View(tree, camera, tf, memo)
    stats = {"culled": 0, "transparent": 0, "projected": 0, "below_error": 0}

    def priority(lv, b):
        if lv == 0:
            return 0.0
        if view.pixels_per_voxel(tree, lv, b) <= 1.0:
            stats["projected"] += 1
            return 0.0
        if tf is None:
            z = view.depth(tree, lv, b)
            e = float(tree.row(lv, b)["E"])
            return math.inf if z <= 0 and e > 0 else e / max(z, 1e-12)
        err = view.tf_error(tree, lv, b)
        if err <= max_pixel_error:
            stats["below_error"] += 1
            return 0.0
        return err * view.area(tree, lv, b)

    def keep(lv, b):
        if not view.visible(tree, lv, b):
            stats["culled"] += 1
            return False
        if tf is not None and view.transparent(tree, lv, b):
            stats["transparent"] += 1
            return False
        return True

    sel = _refine(tree, priority, voxels, None, roi, view, keep)
    return sel, stats


# -- tree walking ----------------------------------------------------------------------


def children(tree: Octree, level: int, b, region) -> list[Node]:
    """The children of node (level, b) that meet ``region``."""
    g = tree.geometry.grid(level - 1)
    out = []
    for d in itertools.product((0, 1), repeat=3):
        c = tuple(2 * i + j for i, j in zip(b, d))
        if all(ci < gi for ci, gi in zip(c, g)) and _meets(tree, level - 1, c, region):
            out.append((level - 1, c))
    return out


def _meets(tree, level, b, region) -> bool:
    fp = tree.geometry.footprint(level, b)
    return all(f.start < r.stop and r.start < f.stop for f, r in zip(fp, region))


def _nodes_in(tree, level, region):
    k, f = tree.plan.block, 1 << level
    g = tree.geometry.grid(level)
    ranges = [
        range(r.start // (k * f), min(gi, (r.stop - 1) // (k * f) + 1)) for r, gi in zip(region, g)
    ]
    return list(itertools.product(*ranges))


def node_voxels(tree, level, b) -> int:
    return math.prod(s.stop - s.start for s in tree.geometry.node_box(level, b))


def _refine(tree, priority, voxels, nbytes, roi, view, keep=None) -> list[Node]:
    """Greedy refinement from the root: replace the highest-priority node by its
    children while the budgets allow; nodes with priority 0 are final."""
    region = parse_region(roi, tree.shape)
    keep = keep or (lambda lv, b: view is None or view.visible(tree, lv, b))
    root = (tree.depth, (0, 0, 0))
    if not keep(*root):
        return []
    used_vox = node_voxels(tree, *root)
    used_bytes = tree.chunk_nbytes(*root)
    heap: list = []
    final: list[Node] = []
    count = itertools.count()

    def push(node):
        p = priority(*node)
        if p > 0:
            heapq.heappush(heap, (-p, next(count), node))
        else:
            final.append(node)

    push(root)
    while heap:
        _, _, (lv, b) = heapq.heappop(heap)
        kids = [c for c in children(tree, lv, b, region) if keep(*c)]
        add_vox = sum(node_voxels(tree, *c) for c in kids) - node_voxels(tree, lv, b)
        add_bytes = tree.chunk_nbytes(lv, b) if lv - 1 < tree.depth else 0
        if (voxels is not None and used_vox + add_vox > voxels) or (
            nbytes is not None and used_bytes + add_bytes > nbytes
        ):
            final.append((lv, b))
            final.extend(n for _, _, n in heap)
            break
        used_vox += add_vox
        used_bytes += add_bytes
        for c in kids:
            push(c)
    return sorted(final)


# -- the camera side -------------------------------------------------------------------


class _View:
    """Project node boxes with the rays of a :class:`~volpack.render.camera.Camera`.

    The camera's corner rays give the image plane in voxel coordinates: a point ``p``
    solves ``p = e + t (d00 + u du + v dv)`` (perspective, eye ``e``) or
    ``p = o00 + u ou + v ov + t d`` (orthographic), giving its pixel ``(u, v)`` and depth.
    """

    def __init__(self, tree: Octree, camera, tf=None, memo: dict | None = None) -> None:
        origins, dirs = camera.rays(tree.shape, tree.spacing)
        h, w = dirs.shape[:2]
        if w < 2 or h < 2:
            raise FormatError(f"expected an image of at least 2x2 pixels, found {w}x{h}")
        self.w, self.h = w, h
        self.persp = camera.projection == "perspective"
        o00, d00 = origins[0, 0], dirs[0, 0]
        if self.persp:
            du = (dirs[0, -1] - d00) / (w - 1)
            dv = (dirs[-1, 0] - d00) / (h - 1)
            self.m = np.linalg.inv(np.column_stack([d00, du, dv]))
            self.pixel = float(np.linalg.norm(du))  # lateral pixel size per unit distance
        else:
            ou = (origins[0, -1] - o00) / (w - 1)
            ov = (origins[-1, 0] - o00) / (h - 1)
            self.m = np.linalg.inv(np.column_stack([d00, ou, ov]))
            self.pixel = float(np.linalg.norm(ou))
        self.o = o00
        self.fwd = d00 / np.linalg.norm(d00)
        self.tf = tf
        self._cache: dict = {}
        # view-independent results per node, for this transfer function
        tf_key = None if tf is None else tuple(map(tuple, np.asarray(tf.points).tolist()))
        self._same: dict = {} if memo is None else memo.setdefault(tf_key, {})

    def _corners(self, tree, lv, b) -> np.ndarray:
        key = ("corners", lv, b)  # view-independent: kept across a walk's frames
        if key not in self._same:
            fp = tree.geometry.footprint(lv, b)
            self._same[key] = np.array(
                [
                    [c[0] - 0.5, c[1] - 0.5, c[2] - 0.5]
                    for c in itertools.product(*((s.start, s.stop) for s in fp))
                ]
            )
        return self._same[key]

    def project(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, u, v)`` of points ``p`` (n, 3): ray parameter and pixel coordinates."""
        s = (p - self.o) @ self.m.T
        if self.persp:
            t = s[:, 0]
            safe = np.where(np.abs(t) > 1e-12, t, 1e-12)
            return t, s[:, 1] / safe, s[:, 2] / safe
        return s[:, 0], s[:, 1], s[:, 2]

    def _proj(self, tree, lv, b):
        """``(tmin, umin, vmin, tmax, umax, vmax)`` of the node's box corners (floats:
        reduced once a node and view, not at each test)."""
        key = (lv, b)
        r = self._cache.get(key)
        if r is None:
            s = np.stack(self.project(self._corners(tree, lv, b)))
            r = self._cache[key] = (*s.min(axis=1).tolist(), *s.max(axis=1).tolist())
        return r

    def visible(self, tree, lv, b) -> bool:
        tmin, umin, vmin, tmax, umax, vmax = self._proj(tree, lv, b)
        if self.persp and tmin <= 0:
            return tmax > 0  # straddles the eye plane: keep if any part is ahead
        return not (umax < -0.5 or umin > self.w - 0.5 or vmax < -0.5 or vmin > self.h - 0.5)

    def depth(self, tree, lv, b) -> float:
        """Nearest distance from the eye (perspective) or the image plane (orthographic)."""
        c = self._corners(tree, lv, b)
        if self.persp:
            lo, hi = c.min(axis=0), c.max(axis=0)
            nearest = np.clip(self.o, lo, hi)
            return float(np.linalg.norm(nearest - self.o))
        return float(max(((c - self.o) @ self.fwd).min(), 0.0))

    def pixels_per_voxel(self, tree, lv, b) -> float:
        """Screen size of one of the node's voxels (2^lv input voxels), in pixels."""
        size = float(1 << lv)
        if self.persp:
            return size / max(self.depth(tree, lv, b) * self.pixel, 1e-12)
        return size / self.pixel

    def area(self, tree, lv, b) -> float:
        """Projected area of the node's box, clipped to the image, in pixels."""
        tmin, umin, vmin, _, umax, vmax = self._proj(tree, lv, b)
        if self.persp and tmin <= 0:
            return float(self.w * self.h)
        du = min(umax, self.w) - max(umin, 0.0)
        dv = min(vmax, self.h) - max(vmin, 0.0)
        return float(max(du, 0.0) * max(dv, 0.0))

    def transparent(self, tree, lv, b) -> bool:
        key = ("clear", lv, b)
        if key not in self._same:
            self._same[key] = bool(tf_range(self.tf, *value_range(tree, lv, b))[1][3] <= 0.0)
        return self._same[key]

    def tf_error(self, tree, lv, b) -> float:
        """Eq. 2.7 bound on the colour + opacity error of a ray through the node."""
        key = ("error", lv, b)
        if key not in self._same:
            r = tree.row(lv, b)
            diag = math.sqrt(3.0) * tree.plan.block * (1 << lv)
            self._same[key] = tf_node_error(self.tf, r, diag)
        return self._same[key]


def tf_range(tf, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Component-wise (min, max) of the transfer function's RGBA over ``[lo, hi]``.

    A piecewise-linear function takes its extremes at the interval's ends or at its
    control points, so this is exact (at a step lying on an end both sides count, which
    can only widen the range). This plays the thesis's 2-D range table.
    """
    if hi < lo:
        lo, hi = hi, lo
    pts = np.asarray(tf.points, np.float64)
    xp = pts[:, 0]
    inside = pts[(xp >= lo) & (xp <= hi), 1:]
    ends = np.array([[np.interp(v, xp, pts[:, 1 + c]) for c in range(4)] for v in (lo, hi)])
    rgba = np.concatenate([ends, inside]) if inside.size else ends
    return rgba.min(axis=0), rgba.max(axis=0)


def value_range(tree: Octree, level: int, b) -> tuple[float, float]:
    """Range of the input voxels under node (level, b), from the index alone: its values
    widened by its deviations (a leaf uses its parent's row)."""
    if level == 0 and tree.depth > 0:
        level, b = 1, tuple(i // 2 for i in b)
    r = tree.row(level, b)
    lo = float(r["vmin"]) + float(r["hist"][:, 0].min())
    hi = float(r["vmax"]) + float(r["hist"][:, 1].max())
    return lo, hi


def tf_node_error(tf, row, diag: float) -> float:
    """Largest eq.-2.7 error over the node's 8 deviation bins.

    For the values of bin ``j`` (``[a, b]``) the input voxels lie in ``[a + dn, b + dp]``.
    With the transfer function's colour range ``[Cmin, Cmax]`` and extinction range
    ``[Dmin, Dmax]`` over both, and a segment length ``d``:
    ``errO = exp(-d Dmin) - exp(-d Dmax)`` (largest at ``d = ln(Dmax/Dmin)/(Dmax-Dmin)``,
    else at the diagonal) and ``errC = (Cmax - Cmin)(1 - exp(-d Dmax)) + Cmin errO``
    summed over r, g, b (``d`` = the diagonal).
    """
    vmin, vmax = float(row["vmin"]), float(row["vmax"])
    nb = layout.HIST_BINS
    width = (vmax - vmin) / nb
    worst = 0.0
    for j in range(nb):
        dn, dp = float(row["hist"][j, 0]), float(row["hist"][j, 1])
        if dn == 0.0 and dp == 0.0:
            continue  # no deviation in this bin (or no voxel): exact
        a = vmin + j * width
        b = vmin + (j + 1) * width
        cmin, cmax = tf_range(tf, a + dn, b + dp)
        # extinction per voxel from the one-voxel opacity: tau = -ln(1 - alpha)
        dmin = -math.log1p(-min(float(cmin[3]), 1 - 1e-12))
        dmax = -math.log1p(-min(float(cmax[3]), 1 - 1e-12))
        d_o = diag
        if dmin > 0 and dmax > dmin:
            d_o = min(diag, math.log(dmax / dmin) / (dmax - dmin))
        err_o = math.exp(-d_o * dmin) - math.exp(-d_o * dmax)
        err_o_diag = math.exp(-diag * dmin) - math.exp(-diag * dmax)
        err_c = float(
            np.sum((cmax[:3] - cmin[:3]) * (1 - math.exp(-diag * dmax)) + cmin[:3] * err_o_diag)
        )
        worst = max(worst, err_o + err_c)
    return worst
