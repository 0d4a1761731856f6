"""Read an octree ``.vpk``: node tables, node decoding with an LRU cache, regions and
mixed-resolution selections assembled into one array.

Decoding a node's chunk rebuilds all eight children at once (seed-004 §7.1 step 6): the
parent's ``k^3`` voxels go into the low-pass corner, the decoded details around them,
and one inverse lifting level gives the ``(2k)^3`` block of the next finer level. Those
blocks are what the cache keeps (least recently used dropped first, within a byte
budget); coefficients are not cached. Only the chunks on the path from the root to the
requested nodes are read.

A damaged chunk (checksum or format error) raises :class:`NodeDamaged`, which names the
node and the voxels it covers; with ``on_damage="approximate"`` the node's details are
taken as zero instead (its region comes out at the coarser level's resolution, smoothly
interpolated) and the damage is listed in :attr:`Octree.damaged`, so the rest of the
volume decodes as usual.
"""

from __future__ import annotations

import collections
import functools
import itertools
import math
import threading
from typing import Any

import numpy as np

from ..errors import FormatError, OptionError, reading
from . import layout
from .plan import Plan, apply_corrections, decode_lowpass, to_values

DEFAULT_CACHE = 256 << 20
_NO_BYTES = np.frombuffer(b"", np.uint8)  # read-only, as a payload's bytes: one kernel type


class NodeDamaged(FormatError):
    """A node's chunk cannot be decoded; ``level``, ``index`` and ``region`` say which."""

    def __init__(self, msg: str, level: int, index: tuple[int, int, int], region) -> None:
        super().__init__(msg)
        self.level, self.index, self.region = level, index, region


class Octree:
    """An octree ``.vpk`` opened for level-of-detail access.

    Parameters
    ----------
    source : path, bytes or seekable binary file
    cache_bytes : int
        Budget of the decoded-node cache.
    on_damage : {"raise", "approximate"}
        What a damaged chunk does (see the module docstring).
    """

    def __init__(
        self, source: Any, *, cache_bytes: int = DEFAULT_CACHE, on_damage: str = "raise"
    ) -> None:
        from ..format import header as hh
        from ..format.container import Reader

        if on_damage not in ("raise", "approximate"):
            raise OptionError(f"expected on_damage 'raise' or 'approximate', found {on_damage!r}")
        self._r = source if isinstance(source, Reader) else Reader(source)
        with reading(self._r.path):  # the CLI names the file
            try:
                if self._r.header.get("kind") != layout.KIND:
                    raise FormatError(
                        f"expected an octree .vpk (kind {layout.KIND!r}), found kind "
                        f"{self._r.header.get('kind')!r}; build one with octree=True"
                    )
                if not self._r.seekable:
                    raise FormatError("expected a seekable octree file, found a stream")
                self.plan = Plan.from_header(self._r.header)
                self.geometry = self.plan.geometry
                h = self._r.header
                self.spacing = hh.vector(h.get("spacing", (1, 1, 1)), "spacing", 3, positive=True)
                self.origin = hh.vector(h.get("origin", (0, 0, 0)), "origin", 3)
                self.summary = self._r.summary if isinstance(self._r.summary, dict) else {}
                # the full-resolution level's error (lossy files), read where a decoder uses it
                self.max_error = (
                    hh.optional_number(self.summary.get("max_error"), "summary 'max_error'", lo=0)
                    or 0.0
                )
            except BaseException:
                self._r.close()
                raise
        self.header = self._r.header
        self.depth = self.geometry.depth
        self.shape = self.plan.shape
        self.dtype = np.dtype(self.plan.dtype)
        self.on_damage = on_damage
        self.damaged: list[dict[str, Any]] = []
        self.cache_bytes = int(cache_bytes)
        self._cache: collections.OrderedDict = collections.OrderedDict()
        self._cached = 0
        self._tables: dict[int, np.ndarray] = {}
        self._bounds: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._lock = threading.RLock()
        self.decoded_nodes = 0
        self._root = None
        self._root_sections: dict[int, bytes] | None = None

    # -- index ------------------------------------------------------------------------

    @property
    def bytes_read(self) -> int:
        return self._r.bytes_read

    def table(self, level: int) -> np.ndarray:
        """The node table of ``level`` (one row per node, raster order of its grid)."""
        level = self.geometry.check_level(level)
        with self._lock:
            if level not in self._tables:
                count = math.prod(self.geometry.grid(level))
                key = layout.meta_key(level)
                if (0, key) in self._r:
                    t = layout.decode_table(self._r.read(0, key), count)
                    layout.check_table(t, level, self._stored(level, count))
                else:  # leaves below the root: exact up to the coding error, E = 0
                    t = np.zeros(count, layout.META_DTYPE)
                    t["maxdev"] = self.max_error
                    t["flags"] = layout.SUBTREE_ZERO
                self._tables[level] = t
            return self._tables[level]

    def _stored(self, level: int, count: int) -> np.ndarray:
        """Which nodes of ``level`` have a chunk, from the container's index."""
        out = np.zeros(count, bool)
        for t, key in self._r.keys():
            lv, i = layout.split_key(key)
            if t == 0 and lv == level and i < count:
                out[i] = True
        return out

    def row(self, level: int, index: tuple[int, int, int]) -> np.void:
        return self.table(level)[np.ravel_multi_index(index, self.geometry.grid(level))]

    def chunk_nbytes(self, level: int, index: tuple[int, int, int]) -> int:
        """Bytes of the node's chunk (0 when stripped or a leaf)."""
        if level == 0 and self.depth > 0:
            return 0
        key = layout.node_key(level, int(np.ravel_multi_index(index, self.geometry.grid(level))))
        e = self._r._by_key.get((0, key))
        return 0 if e is None else e.nbytes

    # -- node decoding ----------------------------------------------------------------

    def _sections(self, level, index) -> dict[int, bytes] | None:
        """The node's payload sections, None when it has no chunk; damage handled."""
        if level == self.depth and self._root_sections is not None:
            return self._root_sections
        key = layout.node_key(level, int(np.ravel_multi_index(index, self.geometry.grid(level))))
        if (0, key) not in self._r:
            return None
        try:
            out = layout.decode_payload(self._r.read(0, key))
        except FormatError as e:
            self._damage(level, index, e)
            out = {}
        if level == self.depth:
            self._root_sections = out
        return out

    def _lift_up(self, level, index, low, sections) -> np.ndarray:
        """Inverse-lift node (level, index): its low-pass voxels plus its decoded details
        give its (2k)^3 block of the next finer level."""
        from ..entropy import CODERS
        from ..wavelet import dwt3
        from ..wavelet.sigmap import scan as make_scan

        box = self._child_box(level, index)
        shape = tuple(s.stop - s.start for s in box)
        lv = layout.lift_levels(shape)
        work = np.dtype(self.plan.work)
        if sections != {} and self.plan.coder == "arith":  # one kernel call, without the GIL
            c = self._lift_up_fused(level, index, low, sections, shape, lv, work)
            if c is not None:
                return c
        c = np.zeros(shape, work)
        body = sections.get(layout.HAS_DETAILS) if sections else None
        decoded = sections != {}  # {}: a damaged chunk, already reported
        if body is not None:
            try:
                CODERS[self.plan.coder].decode(body, make_scan(shape, lv, self.plan.order), c)
            except FormatError as e:
                self._damage(level, index, e)
                c[...] = 0
                decoded = False
        if decoded and not self._energy_matches(level, index, c, lv):
            e = FormatError("its details do not carry the error E that its level table records")
            self._damage(level, index, e)
            c[...] = 0
        ls = layout.low_shape(shape)
        if low.shape != ls:
            raise FormatError(f"octree node: expected a low-pass block {ls}, found {low.shape}")
        c[tuple(slice(0, v) for v in ls)] = low
        with self._lock:
            self.decoded_nodes += 1
        return dwt3.inverse(c, lv, self.plan.wavelet, overwrite=True)

    def _lift_up_fused(self, level, index, low, sections, shape, lv, work):
        """:meth:`_lift_up` in one kernel (:mod:`.chunk`): the same voxels, or None when
        the chunk fails a check (the step-by-step path then reports it)."""
        from ..wavelet.dwt3 import band_scale
        from ..wavelet.lifting import SPECS
        from .chunk import chunk_scan, decode_chunk

        ls = layout.low_shape(shape)
        if low.shape != ls:
            return None
        body = sections.get(layout.HAS_DETAILS) if sections else None
        data = _NO_BYTES if body is None else np.frombuffer(body, np.uint8)
        unit = self.plan.codec.step if self.plan.codec is not None else 1.0
        norm = unit * 2.0 ** (1.5 * (level - 1))
        lo, hi = self._energy_bounds(level)
        n = int(np.ravel_multi_index(index, self.geometry.grid(level)))
        c = np.empty(shape, work)
        status = decode_chunk(data, chunk_scan(shape, lv, self.plan.order), 32 if work == np.int32 else 63,
                              band_scale(shape, lv), norm, (lo[n], hi[n]),
                              np.ascontiguousarray(low), c, lv,
                              SPECS[self.plan.wavelet])  # fmt: skip
        if status:
            return None
        with self._lock:
            self.decoded_nodes += 1
        return c

    def _energy_bounds(self, level) -> tuple[np.ndarray, np.ndarray]:
        """``layout.own_energy_range`` of every node of ``level``, made once."""
        from .chunk import energy_bounds

        with self._lock:
            hit = self._bounds.get(level)
            if hit is None:
                e = self.table(level)["E"]
                kids = self.table(level - 1)["E"] if level > 1 else np.zeros(0, np.float32)
                grid = self.geometry.grid(level)
                kgrid = self.geometry.grid(level - 1) if level > 1 else (0, 0, 0)
                hit = self._bounds[level] = energy_bounds(e, kids, grid, kgrid)
            return hit

    def _energy_matches(self, level, index, c, lv) -> bool:
        """The details' own share of ``E^2`` agrees with the node's table row less its
        children's rows (octree-1.md step 7): a cheap check of every decoded detail."""
        unit = self.plan.codec.step if self.plan.codec is not None else 1.0
        own = layout.detail_energy(c, lv, level, unit)
        kids = np.zeros(0)
        if level > 1:
            grid = self.geometry.grid(level - 1)
            idx = [
                np.ravel_multi_index(b, grid)
                for b in itertools.product(*((2 * i, 2 * i + 1) for i in index))
                if all(v < g for v, g in zip(b, grid))
            ]
            kids = self.table(level - 1)["E"][idx]
        lo, hi = layout.own_energy_range(self.row(level, index)["E"], kids)
        return lo <= own <= hi

    def _damage(self, level, index, e) -> None:
        region = self.geometry.footprint(level, index)
        where = ", ".join(f"{a} {s.start}:{s.stop}" for a, s in zip("zyx", region))
        msg = f"octree node (level {level}, block {tuple(index)}) covering {where} is damaged: {e}"
        if self.on_damage == "raise":
            raise NodeDamaged(msg, level, tuple(index), region) from None
        self.damaged.append(
            {"level": level, "index": list(index), "region": where, "error": str(e)}
        )

    def _child_box(self, level, index) -> tuple[slice, slice, slice]:
        """The (2k)^3 block of ``A_{level-1}`` that node (level, index) rebuilds."""
        k2 = 2 * self.plan.block
        n = self.geometry.level_shape(level - 1)
        return tuple(slice(k2 * i, min(k2 * (i + 1), v)) for i, v in zip(index, n))  # type: ignore[return-value]

    def _children(self, level: int, index: tuple[int, int, int]):
        """``(block of A_{level-1}, corrections)`` rebuilt by node (level, index).

        Only the cache and the file are used under the lock; the decoding itself runs
        outside it, so threads decode different nodes at once.
        """
        key = (level, index)
        with self._lock:
            hit = self._cache.get(key)
            if hit is not None:
                self._cache.move_to_end(key)
                return hit
        low = self.node_block(level, index)
        with self._lock:
            sections = self._sections(level, index)
        block = self._lift_up(level, index, low, sections)
        entry = (block, (sections or {}).get(layout.HAS_CORRECTIONS))
        with self._lock:
            self._put(key, entry)
        return entry

    def chunks_for(self, level: int, box) -> frozenset[tuple[int, tuple[int, int, int]]]:
        """The chunks ``(level, index)`` whose decoding gives the ``A_level`` voxels in
        ``box`` (slices in level coordinates, inside the level): the nodes one level up
        whose blocks ``box`` meets, and their ancestors (the root's own voxels need none)."""
        return _chunks_for(self.geometry, level, tuple((s.start, s.stop) for s in box))

    def node_chunks(self, level: int, index, border: int = 0) -> frozenset:
        """:meth:`chunks_for` the node's voxels grown by ``border`` (clipped to the level)."""
        return _node_chunks(self.geometry, level, tuple(index), border)

    def selection_chunks(self, nodes, border) -> set:
        """The union of :meth:`node_chunks` over ``nodes`` (``(level, index)`` pairs),
        each grown by ``border(level)`` voxels (or ``border`` itself, an int): the chunks
        a frame's selection needs (:func:`selection_chunks`)."""
        return selection_chunks(self.geometry, nodes, border)

    def is_cached(self, level: int, index: tuple[int, int, int]) -> bool:
        """Whether chunk ``(level, index)`` is decoded and in the cache."""
        return (level, tuple(index)) in self._cache

    def prefetch(self, chunks, workers: int = 1) -> None:
        """Decode ``chunks`` (``(level, index)`` pairs) into the cache on ``workers``
        threads, coarsest first (each chunk needs its ancestors); what a later read
        returns does not depend on it."""
        by: dict[int, set] = {}
        for lv, b in chunks:
            by.setdefault(int(lv), set()).add(tuple(int(i) for i in b))
        for lv in sorted(by, reverse=True):
            self._warm(lv, by[lv], workers)

    def _warm(self, level: int, nodes, workers: int) -> None:
        """Decode the children of ``nodes`` (all of ``level``) on ``workers`` threads,
        their ancestors first, so that no node is decoded twice."""
        from ..parallel import completed_map

        nodes = sorted(b for b in set(nodes) if (level, b) not in self._cache)
        if not nodes:
            return
        if level < self.depth:
            self._warm(level + 1, {tuple(i // 2 for i in b) for b in nodes}, workers)
        # the calling thread decodes too (a pool's hand-offs took the GIL between chunks)
        for _ in completed_map(lambda b: self._children(level, b), nodes, workers):
            pass

    def node_block(self, level: int, index: tuple[int, int, int]) -> np.ndarray:
        """The node's ``A_level`` voxels as work integers (before the output cast)."""
        if level == self.depth:
            return self._root_entry()[0]
        parent = tuple(i // 2 for i in index)
        block, _ = self._children(level + 1, parent)
        k = self.plan.block
        box = self.geometry.node_box(level, index)
        return block[
            tuple(slice((i % 2) * k, (i % 2) * k + (s.stop - s.start)) for i, s in zip(index, box))
        ]

    def _root_entry(self):
        """``(root low-pass voxels, corrections)``; kept for the reader's lifetime."""
        with self._lock:
            if self._root is None:
                sections = self._sections(self.depth, (0, 0, 0))
                if not sections or layout.HAS_LOWPASS not in sections:
                    region = self.geometry.footprint(self.depth, (0, 0, 0))
                    raise NodeDamaged(
                        "the octree root cannot be decoded, so no level can be",
                        self.depth,
                        (0, 0, 0),
                        region,
                    )
                shape = self.geometry.level_shape(self.depth)
                low = decode_lowpass(self.plan, sections[layout.HAS_LOWPASS], shape)
                self._root = (low, sections.get(layout.HAS_CORRECTIONS))
            return self._root

    def _put(self, key, entry) -> None:
        old = self._cache.pop(key, None)  # two threads may decode the same node
        if old is not None:
            self._cached -= old[0].nbytes
        self._cache[key] = entry
        self._cached += entry[0].nbytes
        while self._cached > self.cache_bytes and len(self._cache) > 1:
            _, old = self._cache.popitem(last=False)
            self._cached -= old[0].nbytes

    # -- regions ------------------------------------------------------------------------

    def level_box(self, level: int, roi=None) -> tuple[slice, slice, slice]:
        """The level-``level`` voxels covering the full-resolution region ``roi``."""
        level = self.geometry.check_level(level)
        region = parse_region(roi, self.shape)
        f = 1 << level
        n = self.geometry.level_shape(level)
        return tuple(slice(s.start // f, min(-(-s.stop // f), v)) for s, v in zip(region, n))  # type: ignore[return-value]

    def values(self, level: int, box: tuple[slice, slice, slice], workers: int = 1,
               out: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
        """Voxels of level ``level`` (output dtype) in ``box`` (level coordinates),
        decoded on ``workers`` threads; written into ``out`` when given (the box's
        shape, the output dtype or float64: the same numbers) and returned."""
        from .resample import put_clipped

        level = self.geometry.check_level(level)
        n = self.geometry.level_shape(level)
        for s, v in zip(box, n):
            if not (0 <= s.start < s.stop <= v):
                raise FormatError(f"expected a box inside the level-{level} shape {n}, found {box}")
        if out is None:
            out = np.empty(tuple(s.stop - s.start for s in box), self.dtype)
        clip = self.plan.clip_range
        if level == self.depth:
            low, corr = self._root_entry()
            vals = to_values(self.plan, low)
            if corr is not None and level == 0:
                apply_corrections(self.plan, corr, vals)
            out[...] = vals[box]
            return out
        k2 = 2 * self.plan.block
        axes = []  # per axis: (block index, its part in the block, where it goes in out)
        for s in box:
            a = []
            for i in range(s.start // k2, (s.stop - 1) // k2 + 1):
                lo, hi = max(s.start, k2 * i), min(s.stop, k2 * (i + 1))
                a.append((i, slice(lo - k2 * i, hi - k2 * i), slice(lo - s.start, hi - s.start)))
            axes.append(a)
        if workers > 1:
            self._warm(level + 1, itertools.product(*([i for i, _, _ in a] for a in axes)), workers)
        for (iz, sz, dz), (iy, sy, dy), (ix, sx, dx) in itertools.product(*axes):
            block, corr = self._children(level + 1, (iz, iy, ix))
            if corr is not None and level == 0:  # corrections address the whole block
                vals = to_values(self.plan, block)
                apply_corrections(self.plan, corr, vals)
                out[dz, dy, dx] = vals[sz, sy, sx]
            elif clip is not None:  # one kernel call: clipped, cast, written
                put_clipped(block[sz, sy, sx], clip[0], clip[1], out[dz, dy, dx])
            else:  # voxel by voxel: convert only the part asked for
                out[dz, dy, dx] = to_values(self.plan, block[sz, sy, sx])
        return out

    def decode(self, level: int = 0, roi=None, workers: int = 1):
        """The volume (or ``roi``, full-resolution ``z0:z1,y0:y1,x0:x1``) at ``level``:
        ``1/2^level`` of the resolution per axis, as a :class:`~volpack.volume.Volume`
        whose spacing and origin place it over the full-resolution grid. ``workers``
        threads decode nodes at once (0: every core); the result does not depend on it."""
        from ..parallel import parse_workers
        from ..volume import Volume

        box = self.level_box(level, roi)
        data = self.values(level, box, parse_workers(workers))
        return Volume(data, spacing=self._spacing(level), origin=self._origin(level, box))

    def _spacing(self, level):
        return tuple(s * (1 << level) for s in self.spacing)

    def _origin(self, level, box):
        f = 1 << level
        return tuple(
            o + ((s.start + 0.5) * f - 0.5) * d for o, s, d in zip(self.origin, box, self.spacing)
        )

    def brick(self, level: int, index: tuple[int, int, int], border: int = 1) -> np.ndarray:
        """The node's voxels grown by ``border`` voxels of its neighbours on every side
        (edge voxels repeated at the volume's border), so that trilinear interpolation
        inside the node matches interpolation over the whole level: no seams."""
        box = self.geometry.node_box(level, index)
        n = self.geometry.level_shape(level)
        grown = tuple(
            slice(max(0, s.start - border), min(v, s.stop + border)) for s, v in zip(box, n)
        )
        vals = self.values(level, grown)
        pad = [
            (border - (s.start - g.start), border - (g.stop - s.stop)) for s, g in zip(box, grown)
        ]
        return np.pad(vals, pad, mode="edge")

    def assemble(self, selection, level: int | None = None, roi=None, interp: str = "nearest"):
        """One array at ``level`` (default: the finest level in ``selection``) over
        ``roi`` (default: the box around the selection), each selected node resampled
        from its own level.

        ``interp="nearest"`` repeats each coarse voxel over its footprint, so every
        output voxel deviates from the input by at most its node's ``maxdev``;
        ``"linear"`` interpolates trilinearly with the neighbours' voxels across node
        borders (seamless).
        """
        from ..volume import Volume

        if interp not in ("nearest", "linear"):
            raise OptionError(f"expected interp 'nearest' or 'linear', found {interp!r}")
        sel = [(int(lv), tuple(int(i) for i in b)) for lv, b in selection]
        if not sel:
            raise FormatError("expected a non-empty selection of nodes")
        m = min(lv for lv, _ in sel) if level is None else self.geometry.check_level(level)
        if roi is None:  # the box around the selection
            fps = [self.geometry.footprint(lv, b) for lv, b in sel]
            roi = tuple(
                slice(min(f[a].start for f in fps), max(f[a].stop for f in fps)) for a in range(3)
            )
        region = parse_region(roi, self.shape)
        tbox = self.level_box(m, region)
        out = np.zeros(tuple(s.stop - s.start for s in tbox), self.dtype)
        for lv, b in sel:
            if lv < m:
                raise FormatError(f"expected nodes at level {m} or coarser, found level {lv}")
            fm = 1 << (lv - m)
            nbox = self.geometry.node_box(lv, b)
            t = [
                slice(max(s.start * fm, tb.start), min(s.stop * fm, tb.stop))
                for s, tb in zip(nbox, tbox)
            ]
            if any(s.stop <= s.start for s in t):
                continue
            v = self.resampled(lv, t, fm, interp)
            dst = tuple(slice(s.start - tb.start, s.stop - tb.start) for s, tb in zip(t, tbox))
            out[dst] = v
        return Volume(out, spacing=self._spacing(m), origin=self._origin(m, tbox))

    def resampled(self, level: int, box, fm: int, interp: str = "linear",
                  out: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
        """Level ``level``'s voxels at the voxel centres of ``box`` (slices of a level
        ``fm`` times finer), as :meth:`assemble` writes a node of that level there:
        the voxels themselves at ``fm == 1``, else repeated (``"nearest"``) or
        interpolated trilinearly with the neighbouring voxels (``"linear"``). Each
        output voxel depends only on its position and the level's voxels, so a box
        over several nodes gives each node's own numbers. Written into ``out`` (the
        box's shape, an integer tree's dtype) when given, and returned."""
        from .resample import axis_weights, trilinear

        if fm == 1 and out is not None:
            return self.values(level, tuple(box), out=out)
        if interp == "nearest" or fm == 1:  # at its own level: exact voxels, weights 0
            idx = [np.arange(s.start, s.stop) // fm for s in box]
            src = tuple(slice(int(i[0]), int(i[-1]) + 1) for i in idx)
            vals = self.values(level, src)
            vals = vals if fm == 1 else vals[np.ix_(*[i - i[0] for i in idx])]
            if out is not None:
                out[...] = vals
                return out
            return vals
        nl = self.geometry.level_shape(level)
        ax = [axis_weights(s.start, s.stop, fm, v) for s, v in zip(box, nl)]
        src = tuple(slice(b, b + int(j1[-1]) + 1) for b, _, j1, _ in ax)
        v = self.values(level, src, out=np.empty(tuple(s.stop - s.start for s in src)))
        return trilinear(v, [a[1] for a in ax], [a[2] for a in ax], [a[3] for a in ax],
                         self.dtype, out)  # fmt: skip

    def close(self) -> None:
        self._r.close()

    def __enter__(self) -> Octree:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


@functools.lru_cache(maxsize=1 << 16)  # asked for every node a walk's frames draw
def _node_chunks(geometry, level: int, index, border: int) -> frozenset:
    n = geometry.level_shape(level)
    box = geometry.node_box(level, index)
    return _chunks_for(geometry, level, tuple((max(0, s.start - border), min(v, s.stop + border))
                                              for s, v in zip(box, n)))  # fmt: skip


def selection_chunks(geometry, nodes, border) -> set:
    """:meth:`Octree.selection_chunks`: per level, the chunk ranges of all its nodes
    marked at once on the grid of the level above, then their ancestors level by level.
    A walk's first frame asked :func:`_node_chunks` for each of its 1039 nodes, 15-20 ms
    of Python (a node's set, its ancestors', then the union) before any decoding began,
    with the other core idle."""
    grow = border if callable(border) else (lambda _level: border)
    by: dict[int, list] = {}
    for lv, b in nodes:
        by.setdefault(int(lv), []).append(b)
    depth, k = geometry.depth, geometry.block
    marks: dict[int, np.ndarray] = {}  # level -> its grid's chunks needed
    for lv, idx in by.items():
        if lv >= depth:  # the root's own voxels need no chunk
            continue
        idx = np.array(idx, np.int64).reshape(-1, 3)
        n = np.array(geometry.level_shape(lv), np.int64)
        g = grow(lv)
        lo = np.maximum(idx * k - g, 0) // (2 * k)  # the node box grown, clipped to the level
        hi = (np.minimum(np.minimum((idx + 1) * k, n) + g, n) - 1) // (2 * k)
        up = marks.setdefault(lv + 1, np.zeros(geometry.grid(lv + 1), bool))
        span = hi - lo
        if span.max() <= 1:  # a node's grown box meets at most two chunks an axis
            for d in np.ndindex(2, 2, 2):
                ok = (span >= d).all(axis=1)
                up[tuple((lo[ok] + d).T)] = True
        else:  # borders wider than a block
            for a, b in zip(lo.tolist(), hi.tolist()):
                up[a[0] : b[0] + 1, a[1] : b[1] + 1, a[2] : b[2] + 1] = True
    out: set = set()
    for lv in range(min(marks, default=depth + 1), depth + 1):
        m = marks.get(lv)
        if m is None:
            continue
        at = np.argwhere(m)
        out.update((lv, (int(z), int(y), int(x))) for z, y, x in at.tolist())
        if lv < depth:  # their ancestors
            up = marks.setdefault(lv + 1, np.zeros(geometry.grid(lv + 1), bool))
            up[tuple((at // 2).T)] = True
    return out


@functools.lru_cache(maxsize=1 << 16)
def _chunks_for(geometry, level: int, box) -> frozenset:
    out: set = set()
    depth = geometry.depth
    if level >= depth:
        return frozenset()
    k2 = 2 * geometry.block
    for p in itertools.product(*(range(a // k2, (b - 1) // k2 + 1) for a, b in box)):
        lv = level + 1
        while lv <= depth and (lv, p) not in out:
            out.add((lv, p))
            lv, p = lv + 1, (p[0] // 2, p[1] // 2, p[2] // 2)
    return frozenset(out)


def parse_region(roi, shape) -> tuple[slice, slice, slice]:
    """``None``, ``"z0:z1,y0:y1,x0:x1"`` or three slices, checked against ``shape``: a
    region reaching outside the volume is an error, not silently clipped."""
    if roi is None:
        return tuple(slice(0, n) for n in shape)  # type: ignore[return-value]
    if isinstance(roi, str):
        parts = roi.split(",")
        if len(parts) != 3:
            raise FormatError(f"expected a region z0:z1,y0:y1,x0:x1, found {roi!r}")
        sl = []
        for p in parts:
            a, sep, b = p.partition(":")
            try:
                sl.append(
                    slice(int(a) if a.strip() else None, int(b) if b.strip() else None)
                    if sep
                    else slice(int(a), int(a) + 1)
                )
            except ValueError:
                raise FormatError(
                    f"expected integer ranges z0:z1,y0:y1,x0:x1, found {roi!r}"
                ) from None
        roi = sl
    out = []
    if len(roi) != 3:
        raise FormatError(f"expected a region of three ranges (z, y, x), found {roi!r}")
    for s, n, ax in zip(roi, shape, "zyx"):
        start = 0 if s.start is None else int(s.start)
        stop = n if s.stop is None else int(s.stop)
        if not (0 <= start < stop <= n) or s.step not in (None, 1):
            raise FormatError(
                f"expected the region's {ax} range inside 0:{n} and non-empty, found {start}:{stop}"
            )
        out.append(slice(start, stop))
    return tuple(out)  # type: ignore[return-value]
