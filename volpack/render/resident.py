"""A walkthrough's selection held as one full-resolution volume, rewritten where it changes.

The paged sampler (:mod:`volpack.render.lod`) looks a sample's node up in the page
table at every segment end and every shaded midpoint; on the benchmark's MRIs that
made a walk frame cost 1.5-3 times a plain frame of the whole volume. When the
octree's full-resolution grid is small enough (:data:`RESIDENT_BUDGET`), a walk
instead keeps that grid as one array across its frames: each selected node is
written over its footprint (a coarse node resampled trilinearly to level-0 voxel
centres from its own level and its neighbours' voxels at that level, as
:meth:`Octree.assemble <volpack.octree.reader.Octree.assemble>` with
``interp="linear"`` does, rounded to the tree's integer dtype), and the cells no
selected node covers hold a value the transfer function shows as transparent (what
the page table's empty cells read). A frame rewrites only the cells of ``k^3``
level-0 voxels whose node changed since the previous frame (a level's changed cells
at once, in aligned boxes cut into pieces on the worker threads), tells the kept
:class:`~volpack.render.prepared.PreparedVolume` which boxes changed (so that
quantised normals, brick ranges and gradients are redone there only), and the plain
ray caster draws it: its fast path, its empty-space skipping and its per-volume
caches.

What the image shows: where every selected node is at level 0 it is the plain
renderer's image of the whole volume restricted to the selection (equal to the paged
path's within the paged path's own 1e-5). A coarse node is sampled through its
upsampled copy: the trilinear interpolation of trilinear samples, rounded to the
dtype, not the coarse trilinear field itself; and near a border between levels the
finer node's samples read the coarser neighbour's upsampled voxels rather than its
own finer border. Measured differences against the paged path are in the README.

Memory: ``(itemsize + 2)`` bytes a voxel of the full-resolution grid (the data and
its quantised normals), plus int16 or float32 gradients for perspective shaded
frames only while the whole stays within the budget; 105 MB for the 301 x 370 x 316
8-bit MRI of the benchmark. A tree whose grid does not fit walks through the paged
sampler, as before (a 1024^3 8-bit octree needs 3 GiB: paged).
"""

from __future__ import annotations

import math
import threading

import numpy as np

from ..parallel import beside, completed_map
from .prepared import SAMPLED, PreparedVolume

#: Bytes a walk's resident volume may take (data, quantised normals and, for
#: perspective frames, gradients): 512 MiB holds an 8-bit grid of 179 M voxels (560^3).
RESIDENT_BUDGET = 512 << 20


def resident_bytes(tree) -> int:
    """What the resident volume of ``tree`` takes without gradients."""
    dt = np.dtype(tree.dtype)
    item = dt.itemsize if dt.type in SAMPLED else 4
    return math.prod(int(n) for n in tree.shape) * (item + 2)


def grid_dtype(tree) -> np.dtype:
    """The resident grid's dtype: the tree's when the ray caster samples it, else float32."""
    dt = np.dtype(tree.dtype)
    return dt if dt.type in SAMPLED else np.dtype(np.float32)


def holds(dtype: np.dtype, fill: float) -> bool:
    """Whether ``dtype`` holds ``fill`` exactly."""
    if dtype.kind == "f":
        return math.isfinite(fill)
    info = np.iinfo(dtype)
    return float(fill).is_integer() and info.min <= fill <= info.max


_MASK = (1 << 20) - 1


def _key(level: int, b) -> int:
    """One int64 naming a node (a cell's content): level, then 20 bits an index."""
    return (level << 60) | (b[0] << 40) | (b[1] << 20) | b[2]


class Reserved:
    """Zeroed arrays made, every page written once, on a helper thread: a walk's resident
    grid and its normal codes, while the caller does other work before the first frame.

    The first write to a page this process has not used before is paid in the kernel,
    and on this machine's virtual memory much more than the zeroing itself: 105 MB of
    grid and codes took 0.2-0.35 s of system CPU inside the first frame (README,
    walk16), with every other stage waiting for it. ``ndarray.fill`` releases the GIL,
    so the helper runs beside the caller's Python. :meth:`take` waits for it.
    """

    def __init__(self, arrays: dict) -> None:
        self._made: dict = {}
        self._thread = threading.Thread(target=self._make, args=(dict(arrays),),
                                        name="volpack-reserve", daemon=True)  # fmt: skip
        self._thread.start()

    def _make(self, arrays) -> None:
        for name, (shape, dtype) in arrays.items():
            a = np.empty(shape, dtype)  # 2 MB pages above 4 MB, as np.zeros would get
            a.fill(0)
            self._made[name] = a

    def take(self, name: str, shape, dtype) -> np.ndarray | None:
        """The zeroed array ``name`` if it was reserved with this shape and dtype (once),
        else None."""
        self._thread.join()
        a = self._made.pop(name, None)
        if a is None or a.shape != tuple(shape) or a.dtype != np.dtype(dtype):
            return None
        return a


class ResidentVolume:
    """The full-resolution grid of an octree's selection, kept across a walk's frames
    (see the module docstring). ``fill`` is the transparent value of uncovered cells
    (it must be representable in the grid's dtype). ``reserved`` (:meth:`reserve`) holds
    the first frame's grid and normal codes, made beforehand."""

    def __init__(self, tree, value_range, budget: int = RESIDENT_BUDGET) -> None:
        self.tree = tree
        self.k = tree.geometry.block
        self.shape = tuple(int(n) for n in tree.shape)
        self.dtype = grid_dtype(tree)
        self.cells = tuple(-(-n // self.k) for n in self.shape)
        self.have = np.full(self.cells, -1, np.int64)  # node key written per cell; -1: fill
        self.fill: float | None = None
        self.value_range = tuple(float(v) for v in value_range)
        self.budget = int(budget)
        self.prep: PreparedVolume | None = None
        self.written = 0  # nodes written over the volume's life
        self.reserved: Reserved | None = None

    def reserve(self, codes: bool) -> None:
        """Make the first frame's grid (and, with ``codes``, its quantised normals'
        array) on a helper thread now (:class:`Reserved`); the images do not change."""
        if self.prep is None and self.reserved is None:
            arrays = {"grid": (self.shape, self.dtype)}
            if codes:
                arrays["codes"] = (self.shape, np.uint16)
            self.reserved = Reserved(arrays)

    def representable(self, fill: float) -> bool:
        """Whether the grid's dtype holds ``fill`` exactly."""
        return holds(self.dtype, fill)

    @staticmethod
    def border(level: int) -> int:
        """Voxels of its level's neighbours a node's write reads around it: one for the
        trilinear resampling of a coarse node, none at full resolution."""
        return 1 if level > 0 else 0

    def update(self, selection, fill: float, workers: int = 1) -> PreparedVolume:
        """The grid for ``selection`` (``[(level, (bz, by, bx)), ...]``, footprints
        disjoint), writing only the cells whose content changed; the chunks those
        writes need are decoded on ``workers`` threads, each level's before its writes
        (:meth:`_write_levels`)."""
        k = self.k
        if self.prep is None or fill != self.fill:  # first frame, or a new transfer function
            res, self.reserved = self.reserved, None
            data = None if res is None else res.take("grid", self.shape, self.dtype)
            if data is None:
                data = np.full(self.shape, fill, self.dtype)
            elif fill != 0 or math.copysign(1.0, fill) < 0:  # reserved zeroed: +0 is there
                data.fill(fill)
            grad_budget = max(0, self.budget - data.nbytes - 2 * data.size)
            self.prep = PreparedVolume(data, tuple(self.tree.spacing), None, self.value_range,
                                       grad_budget)  # fmt: skip
            if res is not None:
                self.prep.codes_out = res.take("codes", self.shape, np.uint16)
            self.have[:] = -1
            self.fill = fill
        g = self.tree.geometry
        want = np.full(self.cells, -1, np.int64)
        for lv, b in selection:
            lv, b = int(lv), tuple(int(i) for i in b)
            want[tuple(slice(s.start // k, -(-s.stop // k)) for s in g.footprint(lv, b))] = _key(lv, b)
        changed = want != self.have
        data = self.prep.data
        for box in cell_boxes(changed & (want == -1), k, self.shape):  # no longer drawn
            data[box] = fill
        nodes = [(key >> 60, ((key >> 40) & _MASK, (key >> 20) & _MASK, key & _MASK))
                 for key in np.unique(want[changed]).tolist() if key >= 0]  # (re)drawn
        # each level's field is written over aligned boxes of its (re)drawn cells, not node
        # by node: one read of the level's voxels a box (what assemble() writes per node,
        # resampled.__doc__); the boxes are disjoint, so any thread and order give the bytes
        level = np.where(want >= 0, want >> 60, -1)
        levels = sorted({lv for lv, _ in nodes}, reverse=True)  # coarsest first
        boxes = {lv: [(lv, piece) for box in cell_boxes(changed & (level == lv), k, self.shape)
                      for piece in _pieces(box, PIECE)] for lv in levels}  # fmt: skip
        direct = data.dtype == self.tree.dtype and data.dtype.kind in "iu"

        def write(job) -> None:
            lv, box = job
            if direct:  # the tree's integers written straight into the grid
                self.tree.resampled(lv, box, 1 << lv, "linear", out=data[box])
                return
            v = self.tree.resampled(lv, box, 1 << lv, "linear")
            if v.dtype.kind == "f":  # non-finite voxels are empty, as the plain renderer has them
                v = np.where(np.isfinite(v), v, fill)
            data[box] = v

        if workers > 1:
            self._write_levels(levels, nodes, boxes, write, workers)
        else:
            for lv in levels:
                for job in boxes[lv]:
                    write(job)
        self.have = want
        self.written += len(nodes)
        self.prep.rewritten(cell_boxes(changed, k, self.shape))
        return self.prep

    def _write_levels(self, levels, nodes, boxes, write, workers: int) -> None:
        """Decode the chunks of the (re)drawn nodes and ``write`` the levels' ``boxes``.
        When the levels below the coarsest drawn one leave at least :data:`BESIDE`
        chunks to decode (a walk's first frame), coarsest level first: its chunks on
        every worker, then, while this thread writes a level's boxes, the other workers
        decode the next level's chunks (the writes gain nothing from a second thread on
        this machine: the MRI walk's first frame wrote for 69 ms on one thread and 70 on
        two, 100 ms of CPU; its level-1 writes and level-0 chunks take about as long, so
        the one hides the other). Otherwise (a later frame's few new nodes, where the
        hand-overs would cost more than they hide) all the chunks on every worker, then
        all the boxes."""
        if not levels:
            return
        need = [self.tree.selection_chunks([n for n in nodes if n[0] == lv], self.border)
                for lv in levels]  # fmt: skip
        finer = set().union(*need[1:]) - need[0]
        if sum(not self.tree.is_cached(*c) for c in finer) < BESIDE:
            self.tree.prefetch(set().union(*need), workers)
            for _ in completed_map(write, [job for lv in levels for job in boxes[lv]], workers=workers):
                pass
            return
        self.tree.prefetch(need[0], workers)
        for i, lv in enumerate(levels):
            todo = set() if i + 1 == len(levels) else {
                c for c in need[i + 1] if not self.tree.is_cached(*c)}  # fmt: skip
            if not todo:  # the last level, or nothing to decode beside: every worker writes
                for _ in completed_map(write, boxes[lv], workers=workers):
                    pass
                continue
            ahead = beside(self.tree.prefetch, todo, workers - 1, name="volpack-decode")
            try:
                for job in boxes[lv]:
                    write(job)
            finally:
                failed = ahead.exception()  # waits for it (this thread's error goes first)
            if failed is not None:
                raise failed


#: Chunks left to decode below the coarsest drawn level from which a frame's writes
#: overlap that decoding (:meth:`ResidentVolume._write_levels`): the MRI walk's first
#: frame has about 80, its later frames a few.
BESIDE = 16


#: Edge (voxels) of the pieces a frame's writes are cut into: float64 resampling
#: buffers of 2 MB a piece, and pieces enough to share among the threads.
PIECE = 64


def _pieces(box, size: int):
    """``box`` (three slices) cut into boxes of at most ``size`` voxels a side."""
    z, y, x = (range(s.start, s.stop, size) for s in box)
    for a in z:
        for b in y:
            for c in x:
                yield tuple(slice(i, min(i + size, s.stop)) for i, s in zip((a, b, c), box))


def cell_boxes(cells: np.ndarray, k: int, shape) -> list[tuple[slice, slice, slice]]:
    """Boxes of full-resolution voxels that cover the marked ``cells`` (of ``k^3``
    voxels) exactly: the largest blocks of ``2^L`` cells a side, aligned as the
    octree's nodes are, whose cells are all marked. A refined node's children come back
    as its one box, so what is redone per box after a frame (brick ranges, the empty
    bricks' test) runs once per refined region, not once per child (on the MRI's walk,
    about 500 boxes a refining frame took 0.15-0.3 s)."""
    full = [cells]
    while max(full[-1].shape) > 1:  # full[L]: blocks of 2^L cells all marked (outside counts)
        f = np.pad(full[-1], [(0, n % 2) for n in full[-1].shape], constant_values=True)
        full.append(f.reshape(f.shape[0] // 2, 2, f.shape[1] // 2, 2, f.shape[2] // 2, 2)
                    .all(axis=(1, 3, 5)))  # fmt: skip
    boxes = []
    for lv in range(len(full) - 1, -1, -1):
        f = full[lv]
        if lv + 1 < len(full):  # a block whose parent is all marked is in the parent's box
            up = full[lv + 1].repeat(2, 0).repeat(2, 1).repeat(2, 2)
            f = f & ~up[: f.shape[0], : f.shape[1], : f.shape[2]]
        size = k << lv
        for c in np.argwhere(f).tolist():
            boxes.append(tuple(slice(i * size, min((i + 1) * size, n)) for i, n in zip(c, shape)))
    return boxes
