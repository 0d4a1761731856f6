"""Level-of-detail ray casting of octree ``.vpk`` files (thesis §2.3, digest §7).

For each view, :func:`volpack.octree.select.by_view` chooses the nodes to draw (frustum
culling, transparent nodes dropped, refinement by the transfer-function-aware
screen-space error within a voxel budget). The chosen nodes are decoded (through the
octree's LRU cache, so a walkthrough decodes only what it has not seen), each with one
voxel of its neighbours around it, into an atlas of ``(k + 2)^3`` bricks; a page table at
the finest chosen level's node size maps level-0 positions to their node. The ray caster
of :mod:`volpack.render.raycast` samples through the page table, each sample trilinear in
its own node's resolution; the borders make interpolation continuous across nodes of the
same level, so there are no seams there (between levels the coarser node is sampled at
its resolution, as in the thesis).
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import numpy as np

from ..errors import VolpackError


@dataclasses.dataclass
class PagedVolume:
    """A mixed-resolution selection ready for the ray caster (see the module docstring)."""

    atlas: np.ndarray  # (nodes, k + 2, k + 2, k + 2) float32
    page: np.ndarray  # int64 grid over level-0 cells of ``cell`` voxels: node or -1
    level: np.ndarray  # int64 (nodes,)
    origin: np.ndarray  # int64 (nodes, 3): first voxel of the node at its level
    shape: tuple[int, int, int]  # level-0 shape
    spacing: tuple[float, float, float]
    cell: int

    @property
    def meta(self) -> np.ndarray:
        return np.array([*self.shape, self.cell], np.int64)


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


def paged_volume(tree, selection, bricks: dict | None = None) -> PagedVolume:
    """Decode ``selection`` (``[(level, (bz, by, bx)), ...]``) of an open
    :class:`~volpack.octree.Octree` into a :class:`PagedVolume`.

    ``bricks``, a dict kept by the caller from frame to frame, holds each node's
    bordered float32 brick, so a walkthrough assembles a node once while it stays in
    view (the nodes the selection no longer holds are dropped from it)."""
    sel = [(int(lv), tuple(int(i) for i in b)) for lv, b in selection]
    if not sel:
        raise VolpackError("expected at least one node to draw, found none")
    g = tree.geometry
    k = g.block
    m = min(lv for lv, _ in sel)
    cell = k << m
    shape = tuple(int(n) for n in tree.shape)
    page = np.full(tuple(-(-n // cell) for n in shape), -1, np.int64)
    atlas = np.empty((len(sel), k + 2, k + 2, k + 2), np.float32)
    level = np.empty(len(sel), np.int64)
    origin = np.empty((len(sel), 3), np.int64)
    kept = {}
    for i, (lv, b) in enumerate(sel):
        padded = None if bricks is None else bricks.get((lv, b))
        if padded is None:
            brick = tree.brick(lv, b, border=1).astype(np.float32)
            pad = [(0, k + 2 - n) for n in brick.shape]
            padded = np.pad(brick, pad, mode="edge") if any(p[1] for p in pad) else brick
        atlas[i] = padded
        kept[(lv, b)] = padded
        level[i] = lv
        origin[i] = [s.start for s in g.node_box(lv, b)]
        fp = g.footprint(lv, b)
        page[tuple(slice(s.start // cell, -(-s.stop // cell)) for s in fp)] = i
    if bricks is not None:
        bricks.clear()
        bricks.update(kept)
    return PagedVolume(atlas, page, level, origin, shape, tuple(tree.spacing), cell)


def render_lod(
    tree,
    *,
    tf,
    camera,
    voxels: int | None = None,
    blocks: int | None = None,
    max_pixel_error: float = 1.0 / 128,
    value_range: tuple[float, float] | None = None,
    bricks: dict | None = None,
    **render_options: Any,
) -> tuple[np.ndarray, LodStats]:
    """Render an open octree for ``camera`` within a budget of ``voxels`` (``blocks``
    full nodes' worth: nodes at the volume's edge are smaller and count for what they
    hold); ``render_options`` go to :func:`volpack.render.raycast.render`.
    The value range defaults to the octree's recorded one; ``bricks`` (a dict kept
    across the frames of a walk) is passed to :func:`paged_volume`."""
    from ..octree import select
    from .raycast import render

    if blocks is not None:
        voxels = int(blocks) * tree.geometry.block**3
    before_nodes, before_bytes = tree.decoded_nodes, tree.bytes_read
    t0 = time.perf_counter()
    sel, st = select.by_view(tree, camera, tf=tf, voxels=voxels, max_pixel_error=max_pixel_error)
    t1 = time.perf_counter()
    if value_range is None:
        value_range = tree_range(tree)
    w, h = camera.size
    if not sel:  # nothing visible
        img = np.zeros((h, w, 4), np.float32)
        t2 = t3 = time.perf_counter()
    else:
        pv = paged_volume(tree, sel, bricks)
        t2 = time.perf_counter()
        img = render(pv, tf=tf, camera=camera, value_range=value_range, **render_options)
        t3 = time.perf_counter()
    levels: dict[int, int] = {}
    nvox = 0
    for lv, b in sel:
        levels[int(lv)] = levels.get(int(lv), 0) + 1
        nvox += int(np.prod([s.stop - s.start for s in tree.geometry.node_box(lv, b)]))
    return img, LodStats(
        nodes=len(sel), voxels=nvox, decoded=tree.decoded_nodes - before_nodes,
        bytes_read=tree.bytes_read - before_bytes, select_s=t1 - t0, decode_s=t2 - t1,
        render_s=t3 - t2, culled=st["culled"], transparent=st["transparent"], levels=levels,
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
