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

import functools
import heapq
import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import FormatError, OptionError
from . import layout
from .reader import Octree, parse_region

Node = tuple[int, tuple[int, int, int]]
_BITS = np.array(list(itertools.product((0, 1), repeat=3)), bool)  # a box's corners: lo or hi


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
    decode: int | None = None,
    border: Callable[[int], int] | None = None,
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

    ``decode`` caps the chunks that drawing the selection decodes (those not in the
    tree's cache; ``border(level)``: the voxels of its neighbours a node is drawn with,
    :class:`DecodeBudget`): refinement follows the same order, and the first refinement
    the cap does not allow stops every later one that needs a chunk not decoded yet, so
    what is decoded is what the uncapped selection would decode first. A walk that
    keeps its tree's cache thus starts from coarse nodes and refines over the next
    frames until no refinement is held back: then each frame's selection is the
    uncapped one.

    Returns the selection and counts (culled, transparent, stopped by projection,
    ``held``: refinements the decode cap held back, ``chunks``: chunks planned).
    """
    view = _View(tree, camera, tf, memo)
    stats = {"culled": 0, "transparent": 0, "projected": 0, "below_error": 0, "held": 0,
             "chunks": 0}  # fmt: skip
    budget = None if decode is None else DecodeBudget(tree, decode, border)

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

    sel = _refine(tree, priority, voxels, None, roi, view, keep, budget)
    if budget is not None:
        stats["held"], stats["chunks"] = budget.held, len(budget.planned)
    return sel, stats


class DecodeBudget:
    """The chunks a selection may have decoded: at most ``nodes`` not in the tree's
    cache (the first refinement that needs any is allowed whatever it costs, so that a
    walk always progresses). Drawing a node reads its voxels grown by ``border(level)``
    voxels of its neighbours (default 2, the paged atlas's bricks), which can need the
    chunks of neighbours that are not refined themselves: they count."""

    def __init__(self, tree: Octree, nodes: int, border: Callable[[int], int] | None = None):
        if not (isinstance(nodes, (int, np.integer)) and nodes >= 0):
            raise OptionError(f"expected a decode budget of >= 0 nodes, found {nodes!r}")
        self.tree, self.left = tree, int(nodes)
        self.border = border or (lambda level: 2)
        self.planned: set = set()
        self.held = 0

    def allows(self, node, kids) -> bool:
        """Whether drawing ``kids`` (the kept children of refining ``node``) fits; if
        so, their new chunks are counted as planned."""
        t, new = self.tree, set()
        if self.held and kids and node not in self.planned and not t.is_cached(*node):
            self.held += 1  # its own chunk is new: held without looking further
            return False
        for lv, b in kids:
            for c in t.node_chunks(lv, b, self.border(lv)):
                if c not in self.planned and not t.is_cached(*c):
                    new.add(c)
        if new and (self.held or (len(new) > self.left and self.planned)):
            self.held += 1
            return False
        self.planned |= new
        self.left -= len(new)
        return True


# -- tree walking ----------------------------------------------------------------------


def children(tree: Octree, level: int, b, region) -> list[Node]:
    """The children of node (level, b) that meet ``region``."""
    kids = _kids(tree.geometry, level, tuple(b))
    if all(r.start == 0 and r.stop == n for r, n in zip(region, tree.shape)):
        return list(kids)
    return [c for c in kids if _meets(tree, *c, region)]


@functools.lru_cache(maxsize=1 << 16)  # asked for each refined node of every frame of a walk
def _kids(geometry, level: int, b) -> tuple[Node, ...]:
    g = geometry.grid(level - 1)
    out = []
    for d in itertools.product((0, 1), repeat=3):
        c = (2 * b[0] + d[0], 2 * b[1] + d[1], 2 * b[2] + d[2])
        if c[0] < g[0] and c[1] < g[1] and c[2] < g[2]:
            out.append((level - 1, c))
    return tuple(out)


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
    return _voxels(tree.geometry, level, tuple(b))


@functools.lru_cache(maxsize=1 << 16)
def _voxels(geometry, level: int, b) -> int:
    return math.prod(s.stop - s.start for s in geometry.node_box(level, b))


def _refine(tree, priority, voxels, nbytes, roi, view, keep=None, decode=None) -> list[Node]:
    """Greedy refinement from the root: replace the highest-priority node by its
    children while the budgets allow; nodes with priority 0 are final. Past the first
    refinement a :class:`DecodeBudget` ``decode`` holds back, only those that decode
    nothing new go on."""
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
        if decode is not None and not decode.allows((lv, b), kids):
            final.append((lv, b))
            continue
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

    The tests are found in numpy a whole level at a time, the first time the
    refinement reaches that level, and then looked up: each node's visibility,
    projected area and depth per view, its transparency and transfer-function error
    once for a walk (kept in ``memo``). Node by node, the first frame of a walk of the
    1039-node MRI spent about 1 s in them and each later frame 0.1 s.
    """

    def __init__(self, tree: Octree, camera, tf=None, memo: dict | None = None) -> None:
        w, h = camera.size
        if w < 2 or h < 2:
            raise FormatError(f"expected an image of at least 2x2 pixels, found {w}x{h}")
        origins, dirs = camera.corner_rays(tree.shape, tree.spacing)
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
        self._levels: dict = {}  # (visible, area, depth) per level, this view
        self._grid = [tree.geometry.grid(lv) for lv in range(tree.depth + 1)]
        # view-independent results per level, for this transfer function
        tf_key = None if tf is None else tuple(map(tuple, np.asarray(tf.points).tolist()))
        self._same: dict = {} if memo is None else memo.setdefault(tf_key, {})

    def _index(self, lv, b) -> int:
        g = self._grid[lv]
        return (b[0] * g[1] + b[1]) * g[2] + b[2]

    def _bounds(self, tree, lv) -> tuple[np.ndarray, np.ndarray]:
        """``(lo, hi)``, (n, 3) each: the box corners of every node of level ``lv`` in
        raster order (voxel centres at integers, so a box spans its voxels' edges)."""
        key = ("bounds", lv)
        if key not in self._same:
            g = tree.geometry
            k, f = g.block, 1 << lv
            axes = []
            for i, (n, ln) in enumerate(zip(tree.shape, g.level_shape(lv))):
                start = np.arange(g.grid(lv)[i]) * k
                stop = np.minimum(start + k, ln)
                axes.append((start * f - 0.5, np.minimum(stop * f, n) - 0.5))
            grids = [np.meshgrid(*c, indexing="ij") for c in zip(*axes)]
            lo, hi = (np.stack([a.ravel() for a in m], axis=1).astype(np.float64) for m in grids)
            self._same[key] = (lo, hi)
        return self._same[key]

    def _level(self, tree, lv) -> tuple[list, list, list]:
        """``(visible, area, depth)`` of every node of level ``lv`` (raster order) in
        this view, from one projection of all their box corners."""
        r = self._levels.get(lv)
        if r is not None:
            return r
        lo, hi = self._bounds(tree, lv)
        n = len(lo)
        corners = np.where(_BITS[:, None, :], hi, lo)  # (8, n, 3)
        s = _product(corners.reshape(-1, 3) - self.o, self.m.T).reshape(8, n, 3)
        t = s[..., 0]
        if self.persp:
            safe = np.where(np.abs(t) > 1e-12, t, 1e-12)
            u, v = s[..., 1] / safe, s[..., 2] / safe
        else:
            u, v = s[..., 1], s[..., 2]
        tmin, tmax = t.min(axis=0), t.max(axis=0)
        umin, umax, vmin, vmax = u.min(axis=0), u.max(axis=0), v.min(axis=0), v.max(axis=0)
        inside = ~((umax < -0.5) | (umin > self.w - 0.5) | (vmax < -0.5) | (vmin > self.h - 0.5))
        du = np.minimum(umax, self.w) - np.maximum(umin, 0.0)
        dv = np.minimum(vmax, self.h) - np.maximum(vmin, 0.0)
        area = np.maximum(du, 0.0) * np.maximum(dv, 0.0)
        if self.persp:
            behind = tmin <= 0  # straddles the eye plane: kept if any part is ahead
            visible = np.where(behind, tmax > 0, inside)
            area = np.where(behind, float(self.w * self.h), area)
            near = np.clip(self.o, lo, hi) - self.o
            depth = np.sqrt((near[:, None, :] @ near[:, :, None])[:, 0, 0])
        else:
            visible = inside
            along = _product(corners.reshape(-1, 3) - self.o, self.fwd[:, None])
            depth = np.maximum(along.reshape(8, n).min(axis=0), 0.0)
        r = self._levels[lv] = (visible.tolist(), area.tolist(), depth.tolist())
        return r

    def visible(self, tree, lv, b) -> bool:
        return self._level(tree, lv)[0][self._index(lv, b)]

    def depth(self, tree, lv, b) -> float:
        """Nearest distance from the eye (perspective) or the image plane (orthographic)."""
        return self._level(tree, lv)[2][self._index(lv, b)]

    def pixels_per_voxel(self, tree, lv, b) -> float:
        """Screen size of one of the node's voxels (2^lv input voxels), in pixels."""
        size = float(1 << lv)
        if self.persp:
            return size / max(self.depth(tree, lv, b) * self.pixel, 1e-12)
        return size / self.pixel

    def area(self, tree, lv, b) -> float:
        """Projected area of the node's box, clipped to the image, in pixels."""
        return self._level(tree, lv)[1][self._index(lv, b)]

    def transparent(self, tree, lv, b) -> bool:
        key = ("clear", lv)
        if key not in self._same:
            lo, hi = value_ranges(tree, lv)
            self._same[key] = (tf_ranges(self.tf, lo, hi)[1][:, 3] <= 0.0).tolist()
        return self._same[key][self._index(lv, b)]

    def tf_error(self, tree, lv, b) -> float:
        """Eq. 2.7 bound on the colour + opacity error of a ray through the node."""
        key = ("error", lv)
        if key not in self._same:
            diag = math.sqrt(3.0) * tree.plan.block * (1 << lv)
            self._same[key] = tf_node_errors(self.tf, tree.table(lv), diag).tolist()
        return self._same[key][self._index(lv, b)]


def _product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` in slices of 4096 rows: each row's numbers are those of its own product
    (as node-by-node selection had them), and BLAS keeps each slice on one thread,
    where its threads over a whole level took 30-90 ms on the loaded 2-core machine
    instead of 1."""
    out = np.empty((len(a), b.shape[1]))
    for i in range(0, len(a), 4096):
        np.matmul(a[i : i + 4096], b, out=out[i : i + 4096])
    return out


def tf_ranges(tf, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Component-wise ``(min, max)``, (n, 4) each, of the transfer function's RGBA over
    each interval ``[lo[i], hi[i]]`` (ends in either order).

    A piecewise-linear function takes its extremes at the interval's ends or at its
    control points, so this is exact (at a step lying on an end both sides count, which
    can only widen the range). This plays the thesis's 2-D range table.
    """
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    lo, hi = np.where(hi < lo, hi, lo), np.where(hi < lo, lo, hi)
    pts = np.asarray(tf.points, np.float64)
    xp, rgba = pts[:, 0], pts[:, 1:]
    ends = [np.empty((len(lo), 4)) for _ in (lo, hi)]
    for v, e in zip((lo, hi), ends):
        for c in range(4):
            e[:, c] = np.interp(v, xp, rgba[:, c])
    cmin, cmax = np.minimum(*ends), np.maximum(*ends)
    # the control points inside each interval, one point at a time over (n, 4) rather
    # than an (n, points, 4) stack reduced along its middle axis (2.6x as fast: the
    # first frame of a walk looks up every level's ranges)
    for x, v in zip(xp.tolist(), rgba):
        inside = ((lo <= x) & (x <= hi))[:, None]
        np.minimum(cmin, v, out=cmin, where=inside)
        np.maximum(cmax, v, out=cmax, where=inside)
    return cmin, cmax


def value_ranges(tree: Octree, level: int) -> tuple[np.ndarray, np.ndarray]:
    """Range of the input voxels under every node of ``level`` (raster order), from the
    index alone: its values widened by its deviations (a leaf takes its parent's row)."""
    if level == 0 and tree.depth > 0:
        lo, hi = value_ranges(tree, 1)
        g, gp = tree.geometry.grid(0), tree.geometry.grid(1)
        iz, iy, ix = np.meshgrid(*(np.arange(n) // 2 for n in g), indexing="ij")
        parent = ((iz * gp[1] + iy) * gp[2] + ix).ravel()
        return lo[parent], hi[parent]
    t = tree.table(level)
    lo = t["vmin"].astype(np.float64) + t["hist"][:, :, 0].min(axis=1).astype(np.float64)
    hi = t["vmax"].astype(np.float64) + t["hist"][:, :, 1].max(axis=1).astype(np.float64)
    return lo, hi


def tf_node_errors(tf, rows: np.ndarray, diag: float) -> np.ndarray:
    """Largest eq.-2.7 error over each node's 8 deviation bins (``rows``: node table rows).

    For the values of bin ``j`` (``[a, b]``) the input voxels lie in ``[a + dn, b + dp]``.
    With the transfer function's colour range ``[Cmin, Cmax]`` and extinction range
    ``[Dmin, Dmax]`` over both, and a segment length ``d``:
    ``errO = exp(-d Dmin) - exp(-d Dmax)`` (largest at ``d = ln(Dmax/Dmin)/(Dmax-Dmin)``,
    else at the diagonal) and ``errC = (Cmax - Cmin)(1 - exp(-d Dmax)) + Cmin errO``
    summed over r, g, b (``d`` = the diagonal). A bin with no deviation (or no voxel) is
    exact.
    """
    n, nb = len(rows), layout.HIST_BINS
    if n == 0:
        return np.zeros(0)
    vmin, vmax = rows["vmin"].astype(np.float64), rows["vmax"].astype(np.float64)
    width = (vmax - vmin) / nb
    j = np.arange(nb)
    dn, dp = (rows["hist"][:, :, i].astype(np.float64) for i in (0, 1))  # (n, bins)
    a = vmin[:, None] + j * width[:, None]
    b = vmin[:, None] + (j + 1) * width[:, None]
    cmin, cmax = tf_ranges(tf, (a + dn).ravel(), (b + dp).ravel())
    # extinction per voxel from the one-voxel opacity: tau = -ln(1 - alpha)
    dmin = -np.log1p(-np.minimum(cmin[:, 3], 1 - 1e-12))
    dmax = -np.log1p(-np.minimum(cmax[:, 3], 1 - 1e-12))
    with np.errstate(divide="ignore", invalid="ignore"):
        peak = np.minimum(diag, np.log(dmax / dmin) / (dmax - dmin))
    d_o = np.where((dmin > 0) & (dmax > dmin), peak, diag)
    err_o = np.exp(-d_o * dmin) - np.exp(-d_o * dmax)
    err_o_diag = np.exp(-diag * dmin) - np.exp(-diag * dmax)
    err_c = ((cmax[:, :3] - cmin[:, :3]) * (1 - np.exp(-diag * dmax))[:, None]
             + cmin[:, :3] * err_o_diag[:, None]).sum(axis=1)  # fmt: skip
    err = (err_o + err_c).reshape(n, nb)
    err[(dn == 0.0) & (dp == 0.0)] = 0.0
    return np.fmax(err, 0.0).max(axis=1)
