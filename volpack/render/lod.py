"""Level-of-detail ray casting of octree ``.vpk`` files (thesis §2.3, digest §7).

For each view, :func:`volpack.octree.select.by_view` chooses the nodes to draw (frustum
culling, transparent nodes dropped, refinement by the transfer-function-aware
screen-space error within a voxel budget). The chosen nodes are decoded (through the
octree's LRU cache), each with one voxel of its neighbours around it, into the slots of
a :class:`NodeAtlas` of ``(k + 2)^3`` bricks that a walkthrough keeps from frame to
frame, so a frame decodes and writes only the nodes new to it; with shading, each slot
also holds its node's central differences (a gradient brick), computed once. A page
table at the finest chosen level's node size maps level-0 positions to their slot. The
ray caster of :mod:`volpack.render.raycast` samples through the page table (its fast
path, as for a plain volume), each sample trilinear in its own node's resolution; the
borders make interpolation continuous across nodes of the same level, so there are no
seams there (between levels the coarser node is sampled at its resolution, as in the
thesis).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from typing import Any

import numpy as np

from ..errors import VolpackError
from .normals import normal_codes
from .prepared import GRADIENT_BUDGET, SAMPLED, gradient_dtype, gradient_volume
from .resident import RESIDENT_BUDGET, ResidentVolume, grid_dtype, holds, resident_bytes

log = logging.getLogger(__name__)

#: Voxels of its neighbours a node's atlas brick is read with (one stays as its border,
#: both give the central differences of the border voxels).
BORDER = 2


@dataclasses.dataclass
class PagedVolume:
    """A mixed-resolution selection ready for the ray caster (see the module docstring)."""

    atlas: np.ndarray  # (slots, k + 2, k + 2, k + 2), the tree's dtype or float32
    page: np.ndarray  # int64 grid over level-0 cells of ``cell`` voxels: slot or -1
    level: np.ndarray  # int64 (slots,)
    origin: np.ndarray  # int64 (slots, 3): first voxel of the node at its level
    shape: tuple[int, int, int]  # level-0 shape
    spacing: tuple[float, float, float]
    cell: int
    finite_range: tuple[float, float] | None = None  # of the drawn nodes' voxels
    grad: np.ndarray | None = None  # (slots, k + 2, k + 2, k + 2, 3) central differences
    codes: np.ndarray | None = None  # (slots, k + 2, k + 2, k + 2) quantised normals


class NodeAtlas:
    """Node bricks kept from frame to frame of a walkthrough, in the slots of one array.

    Each node drawn is decoded once while it stays in the atlas (with two voxels of its
    neighbours: one stays as the brick's border, both give the central differences of
    the border voxels, so each gradient brick covers its node's whole footprint). A
    frame writes only the nodes new to the view into free slots; when none are free the
    atlas grows up to ``keep`` times the current selection and then reuses the slots of
    the nodes least recently drawn.

    Memory: the atlas holds ``(k + 2)^3`` voxels a slot in the tree's dtype (float32 for
    dtypes the ray caster does not sample as they are); with ``gradients`` each slot also
    holds ``3 (k + 2)^3`` int16 differences (integer data whose range fits 32767 exactly)
    or float32, so for 16^3 nodes of 8-bit data 5.8 kB + 35 kB a slot, 42 MB for 1024
    nodes (twice that when ``keep`` slots fill); beside them ``(k + 2)^3`` 16-bit
    quantised normals (:mod:`volpack.render.normals`, 11.7 kB a slot for 16^3 nodes)
    that orthographic frames light through one table. Gradient and normal bricks are
    dropped, and shading falls back to differences taken on the fly, when they would
    pass ``gradient_budget`` bytes.

    When the tree's full-resolution grid fits ``resident_budget`` bytes,
    :func:`render_lod` draws a walk's frames from one
    :class:`~volpack.render.resident.ResidentVolume` instead (the plain ray caster on a
    full-resolution grid rewritten where the selection changes, no page table); 0 keeps
    every frame on the paged sampler.
    """

    def __init__(self, tree, *, gradients: bool = True, keep: float = 2.0,
                 gradient_budget: int = GRADIENT_BUDGET,
                 resident_budget: int = RESIDENT_BUDGET) -> None:  # fmt: skip
        if not keep >= 1:
            raise VolpackError(f"expected keep >= 1 (slots per drawn node), found {keep}")
        if not (isinstance(resident_budget, (int, np.integer)) and resident_budget >= 0):
            raise VolpackError(f"expected a resident budget in bytes >= 0, found {resident_budget!r}")
        self.resident_budget = int(resident_budget)
        self.resident: ResidentVolume | None = None
        self.tree = tree
        self.keep = float(keep)
        self.gradient_budget = int(gradient_budget)
        k = tree.geometry.block
        dt = np.dtype(tree.dtype)
        self.dtype = dt if dt.type in SAMPLED else np.dtype(np.float32)
        self.gdtype = None
        if gradients:
            vr = tree_range(tree) if dt.kind in "iu" else None
            self.gdtype = gradient_dtype(np.empty(0, self.dtype), vr)
        self.atlas = np.zeros((0, k + 2, k + 2, k + 2), self.dtype)
        self.grad = None if self.gdtype is None else np.zeros((*self.atlas.shape, 3), self.gdtype)
        self.codes = None if self.gdtype is None else np.zeros(self.atlas.shape, np.uint16)
        self.level = np.zeros(0, np.int64)
        self.origin = np.zeros((0, 3), np.int64)
        self.vmin = np.zeros(0, np.float64)  # finite voxel range per slot (NaN: none)
        self.vmax = np.zeros(0, np.float64)
        self.slot: dict = {}  # (level, index) -> slot
        self.last: dict = {}  # (level, index) -> frame it was last drawn
        self.free: list[int] = []
        self.frame = 0
        self.placed = 0  # nodes written into slots, over the atlas's life
        self.select_memo: dict = {}  # the selection's view-independent results (select.by_view)

    @property
    def nbytes(self) -> int:
        return self.atlas.nbytes + sum(0 if a is None else a.nbytes for a in (self.grad, self.codes))

    def paged(self, selection, workers: int = 1) -> PagedVolume:
        """The :class:`PagedVolume` of ``selection`` (``[(level, (bz, by, bx)), ...]``),
        the chunks of its nodes new to the atlas decoded first on ``workers`` threads."""
        sel = [(int(lv), tuple(int(i) for i in b)) for lv, b in selection]
        if not sel:
            raise VolpackError("expected at least one node to draw, found none")
        self.frame += 1
        new = [n for n in dict.fromkeys(sel) if n not in self.slot]
        self._make_room(len(new), set(sel))
        if workers > 1:
            self.tree.prefetch(self.tree.selection_chunks(new, BORDER), workers)
        for n in new:
            self._place(n, self.free.pop())
        g = self.tree.geometry
        m = min(lv for lv, _ in sel)
        cell = g.block << m
        shape = tuple(int(n) for n in self.tree.shape)
        page = np.full(tuple(-(-n // cell) for n in shape), -1, np.int64)
        for n in sel:
            self.last[n] = self.frame
            fp = g.footprint(*n)
            page[tuple(slice(s.start // cell, -(-s.stop // cell)) for s in fp)] = self.slot[n]
        slots = np.array([self.slot[n] for n in sel], np.int64)
        lo, hi = np.nanmin(self.vmin[slots]), np.nanmax(self.vmax[slots])
        frange = None if np.isnan(lo) else (float(lo), float(hi))
        return PagedVolume(self.atlas, page, self.level, self.origin, shape,
                           tuple(self.tree.spacing), cell, frange, self.grad, self.codes)  # fmt: skip

    def reserve(self, value_range, *, codes: bool, workers: int | None = None) -> None:
        """Before a walk's first frame, when the frames will draw the resident grid:
        make that grid's memory (and, with ``codes``, its quantised normals') on a helper
        thread while the caller goes on (:meth:`ResidentVolume.reserve`). Not with one
        worker: the helper needs a core of its own."""
        from ..parallel import parse_workers
        from .transfer import nonempty_range

        if parse_workers(workers) < 2 or not 0 < resident_bytes(self.tree) <= self.resident_budget:
            return
        if self.resident is None:
            self.resident = ResidentVolume(self.tree, nonempty_range(*value_range),
                                           self.resident_budget)  # fmt: skip
        self.resident.reserve(codes)

    def dense(self, selection, fill: float, value_range, workers: int = 1):
        """The resident full-resolution grid of ``selection`` (uncovered cells at
        ``fill``), or None when the tree's grid passes the resident budget or its dtype
        cannot hold ``fill`` (the caller then takes :meth:`paged`)."""
        if not self.draws_resident(fill):
            return None
        if self.resident is None:
            self.resident = ResidentVolume(self.tree, value_range, self.resident_budget)
        return self.resident.update(selection, fill, workers)

    def draws_resident(self, fill: float) -> bool:
        """Whether :meth:`dense` takes the resident grid (not the page table) for ``fill``."""
        return 0 < resident_bytes(self.tree) <= self.resident_budget and holds(
            grid_dtype(self.tree), fill
        )

    def _make_room(self, need: int, drawn: set) -> None:
        short = need - len(self.free)
        if short <= 0:
            return
        cap = len(self.atlas)
        limit = max(int(self.keep * len(drawn)), len(drawn))
        grow = min(max(short, cap // 2), max(0, limit - cap))
        if grow >= short:
            self._grow(cap + grow)
            return
        if grow:
            self._grow(cap + grow)
        # evict the nodes drawn longest ago that this frame does not draw
        old = sorted((f, n) for n, f in self.last.items() if n not in drawn)
        for _, n in old[: need - len(self.free)]:
            self.free.append(self.slot.pop(n))
            del self.last[n]

    def _grow(self, cap: int) -> None:
        n = len(self.atlas)
        per = 0 if self.grad is None else (self.grad.itemsize * 3 + 2) * math.prod(self.atlas.shape[1:])
        if self.grad is not None and (gb := cap * per) > self.gradient_budget:
            log.info("gradient bricks would take %d bytes: shading takes them on the fly", gb)
            self.grad = self.codes = None
        self.atlas = _grown(self.atlas, cap)
        if self.grad is not None:
            self.grad = _grown(self.grad, cap)
            self.codes = _grown(self.codes, cap)
        self.level = _grown(self.level, cap)
        self.origin = _grown(self.origin, cap)
        self.vmin = _grown(self.vmin, cap)
        self.vmax = _grown(self.vmax, cap)
        self.free.extend(range(cap - 1, n - 1, -1))

    def _place(self, node, i: int) -> None:
        lv, b = node
        k = self.tree.geometry.block
        raw = self.tree.brick(lv, b, border=BORDER)
        pad = [(0, k + 4 - n) for n in raw.shape]
        if any(p[1] for p in pad):  # a node at the volume's far edge is smaller than k
            raw = np.pad(raw, pad, mode="edge")
        inner = raw[1:-1, 1:-1, 1:-1]
        self.atlas[i] = inner
        if self.grad is not None:  # differences of the grown brick, cut to the brick
            self.grad[i] = gradient_volume(raw, self.gdtype)[1:-1, 1:-1, 1:-1]
            self.codes[i] = normal_codes(raw, self.tree.spacing)[1:-1, 1:-1, 1:-1]
        fin = inner if inner.dtype.kind in "iu" else inner[np.isfinite(inner)]
        self.vmin[i] = fin.min() if fin.size else np.nan
        self.vmax[i] = fin.max() if fin.size else np.nan
        self.level[i] = lv
        self.origin[i] = [s.start for s in self.tree.geometry.node_box(lv, b)]
        self.slot[node] = i
        self.placed += 1


def _grown(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` with its first axis grown to ``n`` (new rows zero)."""
    out = np.zeros((n, *a.shape[1:]), a.dtype)
    out[: len(a)] = a
    return out


@dataclasses.dataclass
class LodStats:
    """One level-of-detail frame."""

    nodes: int  # drawn
    voxels: int  # their voxels (edge nodes are smaller than k^3)
    decoded: int  # decoded for this frame (cache misses)
    bytes_read: int
    select_s: float
    decode_s: float
    render_s: float
    culled: int
    transparent: int
    levels: dict  # nodes per level
    held: int = 0  # refinements the decode budget held back (0: the uncapped selection)
    cpu_s: tuple = (0.0, 0.0, 0.0)  # CPU seconds of the process (all threads) in the three steps


def paged_volume(tree, selection, *, gradients: bool = False) -> PagedVolume:
    """Decode ``selection`` (``[(level, (bz, by, bx)), ...]``) of an open
    :class:`~volpack.octree.Octree` into a :class:`PagedVolume` (with the nodes'
    gradient bricks when ``gradients``); a walkthrough keeps a :class:`NodeAtlas`
    instead, so that each frame decodes only the nodes new to it."""
    return NodeAtlas(tree, gradients=gradients, keep=1.0).paged(selection)


def render_lod(
    tree,
    *,
    tf,
    camera,
    voxels: int | None = None,
    blocks: int | None = None,
    max_pixel_error: float = 1.0 / 128,
    value_range: tuple[float, float] | None = None,
    atlas: NodeAtlas | None = None,
    decode: int | None = None,
    **render_options: Any,
) -> tuple[np.ndarray, LodStats]:
    """Render an open octree for ``camera`` within a budget of ``voxels`` (``blocks``
    full nodes' worth: nodes at the volume's edge are smaller and count for what they
    hold); ``render_options`` go to :func:`volpack.render.raycast.render`.
    The value range defaults to the octree's recorded one; ``atlas`` (a
    :class:`NodeAtlas` of this tree kept across the frames of a walk) keeps the decoded
    nodes, or the resident full-resolution grid when it fits its budget, else one is
    made for this frame (paged, with gradient bricks when shaded). ``decode`` caps the
    chunks the frame decodes (:func:`volpack.octree.select.by_view`): a walk's first
    frame then draws coarser nodes, and its next frames refine them. The chunks are
    decoded on the ``workers`` threads of the render options."""
    from ..octree import select
    from ..parallel import parse_workers
    from .raycast import TABLE_SIZE, empty_value, render, transfer_table
    from .transfer import nonempty_range

    workers = parse_workers(render_options.get("workers"))  # as render() takes it
    if blocks is not None:
        voxels = int(blocks) * tree.geometry.block**3
    if value_range is None:
        value_range = tree_range(tree)
    fill = None
    if atlas is not None and atlas.resident_budget:  # the value uncovered cells hold, as render() finds it
        lo, hi = nonempty_range(*value_range)
        n = int(render_options.get("table_size", TABLE_SIZE))
        base = None if tf is None else transfer_table(tf, lo, hi, n)
        fill = empty_value(base, lo, hi, lo, quiet=True)
        fill = fill if atlas.draws_resident(fill) else None
    before_nodes, before_bytes = tree.decoded_nodes, tree.bytes_read
    t0, c0 = time.perf_counter(), time.process_time()
    memo = None if atlas is None else atlas.select_memo
    sel, st = select.by_view(
        tree, camera, tf=tf, voxels=voxels, max_pixel_error=max_pixel_error, memo=memo,
        decode=decode, border=ResidentVolume.border if fill is not None else lambda lv: BORDER,
    )  # fmt: skip
    t1, c1 = time.perf_counter(), time.process_time()
    w, h = camera.size
    if not sel:  # nothing visible
        img = np.zeros((h, w, 4), np.float32)
        t2 = t3 = time.perf_counter()
        c2 = c3 = time.process_time()
    else:
        if atlas is None:
            shaded = render_options.get("shading", "none") != "none"
            atlas = NodeAtlas(tree, gradients=shaded, keep=1.0)
        if fill is not None:
            pv = atlas.dense(sel, fill, nonempty_range(*value_range), workers)
        else:
            pv = atlas.paged(sel, workers)
        t2, c2 = time.perf_counter(), time.process_time()
        img = render(pv, tf=tf, camera=camera, value_range=value_range, **render_options)
        t3, c3 = time.perf_counter(), time.process_time()
    levels: dict[int, int] = {}
    nvox = 0
    for lv, b in sel:
        levels[int(lv)] = levels.get(int(lv), 0) + 1
        nvox += int(np.prod([s.stop - s.start for s in tree.geometry.node_box(lv, b)]))
    return img, LodStats(
        nodes=len(sel), voxels=nvox, decoded=tree.decoded_nodes - before_nodes,
        bytes_read=tree.bytes_read - before_bytes, select_s=t1 - t0, decode_s=t2 - t1,
        render_s=t3 - t2, culled=st["culled"], transparent=st["transparent"], levels=levels,
        held=st["held"], cpu_s=(c1 - c0, c2 - c1, c3 - c2),
    )  # fmt: skip


def tree_range(tree) -> tuple[float, float]:
    from ..format.header import recorded_range
    from .transfer import nonempty_range

    vr = recorded_range(tree.summary)
    dt = np.dtype(tree.dtype)
    top = np.iinfo(dt) if dt.kind in "iu" else np.finfo(dt)
    if vr is not None and top.min <= vr[0] and vr[1] <= top.max:  # else measured below
        return nonempty_range(*vr)
    root = tree.decode(tree.depth).data
    return float(root.min()), float(root.max())


def coarse_level(tree, voxels: int = 1 << 21):
    """``(volume, factor)``: the finest level of ``tree`` with at most ``voxels`` voxels,
    decoded, and its voxel size in full-resolution voxels (for the automatic transfer
    function and the framing, which need the data's look, not its detail)."""
    level = 0
    while level < tree.depth and int(np.prod(tree.geometry.level_shape(level))) > voxels:
        level += 1
    return tree.decode(level), 1 << level
