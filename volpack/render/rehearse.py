"""A walk's first frame rehearsed on a helper thread, before it is drawn.

A fresh process pays, inside a walk's first frame, for things that do not depend on
the view: the chunk decoder's scans and context tables (one per child-block shape),
the energy bounds of the levels the frame decodes, and the loading of every kernel the
node writes and the ray caster run (numba reads each from its cache and links it, on
first call). While the main thread decodes the coarse level, picks the transfer
function and frames the camera, :class:`Rehearsal` does them on a helper thread: it
builds the scans and bounds the frame will look up (the same objects, cached where the
frame finds them), calls the node-write kernels on a few voxels and draws a 4x4-pixel
image of a tiny grid of the same dtype with the walk's classification, shading and
projection, so the kernels with the frame's signatures are loaded when it calls them.

It never compiles: it runs under :func:`volpack._jit.cached_only`, and a kernel not in
the cache for those arguments (a first run, another dtype) ends that step silently; the
frame then compiles it as it would have. Nothing it makes changes an image: the scans,
bounds and loaded kernels are what the frame would make itself. With one worker
nothing is rehearsed (the helper would take the core the walk has).
"""

from __future__ import annotations

import logging
import threading

import numpy as np

from .._jit import NotCached, cached_only

log = logging.getLogger(__name__)


class Rehearsal:
    """The helper thread (see the module docstring); :meth:`wait` joins it. ``done``
    and ``skipped`` name the steps that ran and those a missing kernel ended."""

    def __init__(self, tree, value_range, options: dict, perspective: bool) -> None:
        self.tree = tree
        self.value_range = tuple(float(v) for v in value_range)
        self.options = dict(options)
        self.perspective = bool(perspective)
        self.done: list[str] = []
        self.skipped: list[str] = []
        self._thread = threading.Thread(target=self._run, name="volpack-rehearse", daemon=True)
        self._thread.start()

    def wait(self) -> None:
        self._thread.join()

    def _run(self) -> None:
        steps = [("scans", self._scans), ("writes", self._writes), ("render", self._render)]
        with cached_only():
            for name, step in steps:
                try:
                    step()
                except NotCached as e:
                    self.skipped.append(name)
                    log.debug("rehearsal step %s: %s", name, e)
                except Exception:  # a rehearsal must never break the walk
                    self.skipped.append(name)
                    log.debug("rehearsal step %s failed", name, exc_info=True)
                else:
                    self.done.append(name)

    def _scans(self) -> None:
        """The chunk decoder's scans and context tables of every child-block shape of
        the tree (``chunk.chunk_scan`` keeps them), and the levels' energy bounds."""
        from ..octree import layout
        from ..octree.chunk import chunk_scan

        tree = self.tree
        if tree.plan.coder != "arith":  # only the fused chunk kernel reads them
            return
        g = tree.geometry
        k2 = 2 * tree.plan.block
        for level in range(1, tree.depth):  # the root's chunk is the coarse level's
            n = g.level_shape(level - 1)
            sides = [{min(k2, v)} | ({v % k2} if v % k2 else set()) for v in n]
            for shape in {(a, b, c) for a in sides[0] for b in sides[1] for c in sides[2]}:
                chunk_scan(shape, layout.lift_levels(shape), tree.plan.order)
        for level in range(1, tree.depth + 1):
            tree._energy_bounds(level)

    def _writes(self) -> None:
        """The node writes' kernels (``ResidentVolume.update``) on a few voxels, in the
        array layouts a frame passes them (whole blocks and parts of blocks)."""
        from ..octree.resample import axis_weights, put_clipped, trilinear
        from .resident import grid_dtype

        tree = self.tree
        clip = tree.plan.clip_range
        grid = grid_dtype(tree)
        j = axis_weights(0, 4, 2, 3)
        trilinear(np.zeros((3, 3, 3)), [j[1]] * 3, [j[2]] * 3, [j[3]] * 3, grid,
                  np.zeros((4, 4, 5), grid)[..., :4])  # a box of the grid: a strided view  # fmt: skip
        if clip is None:
            return
        work = np.dtype(tree.plan.work)
        outs = [np.zeros((2, 2, 2)), np.zeros((2, 2, 3))[..., :2]]  # trilinear's input
        if grid == np.dtype(tree.dtype) and grid.kind in "iu":  # level 0 written in place
            outs += [np.zeros((2, 2, 2), grid), np.zeros((2, 2, 3), grid)[..., :2]]
        for src in (np.zeros((2, 2, 2), work), np.zeros((2, 2, 3), work)[..., :2]):
            for out in outs:
                try:
                    put_clipped(src, clip[0], clip[1], out)
                except NotCached:  # a layout this tree's frames have not used yet
                    pass

    def _render(self) -> None:
        """A 4x4 image of an 8^3 ramp of the grid's dtype, drawn as the walk draws its
        frames (the resident grid's :class:`PreparedVolume`, its options)."""
        from .camera import Camera
        from .prepared import PreparedVolume
        from .raycast import render
        from .resident import grid_dtype
        from .transfer import TransferFunction

        tree = self.tree
        lo, hi = self.value_range
        dt = grid_dtype(tree)
        ramp = np.linspace(lo, hi, 8 * 8 * 8).reshape(8, 8, 8)
        data = np.ascontiguousarray(ramp.astype(dt) if dt.kind == "f" else np.rint(ramp).astype(dt))
        prep = PreparedVolume(data, tuple(tree.spacing), None, self.value_range)
        tf = TransferFunction(points=((lo, 0.0, 0.0, 0.0, 0.0), (hi, 1.0, 0.8, 0.6, 0.5)))
        cam = Camera(size=(4, 4), azimuth=30.0, elevation=20.0,
                     projection="perspective" if self.perspective else "orthographic")  # fmt: skip
        opts = dict(self.options, workers=1)
        render(prep, tf=tf, camera=cam, value_range=self.value_range, table_size=32, **opts)


def rehearse(atlas, value_range, options: dict, perspective: bool, workers) -> Rehearsal | None:
    """Start a :class:`Rehearsal` of a walk's first frame on ``atlas`` (a
    :class:`~volpack.render.lod.NodeAtlas` whose frames draw the resident grid), or
    None: with one worker, or when the frames go through the page table (its kernels
    are others)."""
    from ..parallel import parse_workers
    from .resident import resident_bytes

    tree = atlas.tree
    if parse_workers(workers) < 2 or not 0 < resident_bytes(tree) <= atlas.resident_budget:
        return None
    return Rehearsal(tree, value_range, options, perspective)
