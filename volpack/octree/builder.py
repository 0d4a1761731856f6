"""Build the octree of a volume, out of core, into a ``.vpk`` file (kind ``octree``).

The volume is read one *super-brick* at a time: the footprint of one node of level
``s`` (``k * 2^s`` voxels per axis, 256 for ``k = 16``). A task builds the subtree of
that node completely in memory (levels 1..s: lift, code the details, measure errors)
and returns the coded chunks, the node-table rows and the node's ``k^3`` low-pass block.
Tasks are independent: they run on threads (:func:`volpack.parallel.ordered_map`) or
on a Dask cluster with the same function, and their results are written in task order,
so the file does not depend on the worker count. The low-pass blocks of all tasks form
``A_s`` (1/2^(3s) of the volume), from which the levels above are built the same way.

Peak memory is a few super-bricks per worker plus ``A_s`` and the node tables (about
1/400 of the volume for 8-bit data), never the volume itself.

Lossless (integer volumes): the lifting is exact. ``max_error``: voxels are first
quantised as :class:`volpack.volume_codec.lossy.BoundedCodec` does (bins of ``2E`` for floats,
``2e + 1`` values for integers) and the quantised field is coded exactly, so every voxel
of the full-resolution decode is within the bound; the encoder rebuilds each voxel as the
decoder will and stores any that rounding pushed past the bound exactly.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from .._jit import kernel
from ..errors import FormatError, OptionError
from ..metrics import psnr_from_sse, throughput
from ..parallel import one_blas_thread, ordered_map, parse_workers
from . import layout
from .layout import Geometry
from .plan import Plan, encode_lowpass, to_values
from .source import SourceSpec, open_source

SUPER_BRICK = 256  # voxels per axis a task reads at once (for k = 16: s = 4 levels)


def make_plan(
    shape,
    dtype,
    *,
    block: int = layout.DEFAULT_BLOCK,
    wavelet: str = "53",
    coder: str = "arith",
    order: str = "dfs",
    max_error: float | None = None,
    value_range: tuple[float, float] | None = None,
) -> Plan:
    """Check the options against the volume and fix the work dtype and the quantiser."""
    from ..volume_codec.codec import CODER_NAMES, ORDER_NAMES, WAVELET_DTYPES, WAVELET_NAMES
    from ..volume_codec.protocol import check_choice
    from ..wavelet import dwt3

    check_choice("wavelet", wavelet, WAVELET_NAMES)
    check_choice("coder", coder, CODER_NAMES)
    check_choice("order", order, ORDER_NAMES)
    shape = tuple(int(n) for n in shape)
    if len(shape) != 3:
        raise FormatError(f"expected a 3-D (z, y, x) volume for an octree, found shape {shape}")
    geo = Geometry(shape, int(block))  # type: ignore[arg-type]
    dtype = np.dtype(dtype).newbyteorder("=")
    depth = geo.depth
    bounded = None
    if max_error is None:
        if dtype.name not in WAVELET_DTYPES:
            raise FormatError(
                f"a lossless octree takes {', '.join(WAVELET_DTYPES)} voxels, found {dtype}; "
                "add max_error= for floats"
            )
        info = np.iinfo(dtype)
        lo, hi = int(info.min), int(info.max)
    else:
        from ..volume_codec.lossy import BoundedCodec

        if dtype.kind not in "iuf":
            raise FormatError(
                f"an error-bounded octree takes integer or float voxels, found {dtype}; "
                "store a mask as uint8 (a.astype(np.uint8)) or without an octree"
            )
        if value_range is None:
            raise OptionError("expected the value range for an error-bounded octree")
        # Only its quantiser is used (the octree codes with its own coder): the config
        # keeps the coder it named before the bounded codec's default became auto.
        codec = BoundedCodec.plan(dtype, value_range[0], value_range[1], max_error, coder="arith")
        bounded = tuple(sorted(codec.get_config().items()))
        lo, hi = 0, int(np.iinfo(np.dtype(codec.qdtype)).max)
    work = dwt3.work_dtype(lo, hi, (depth,) * 3, wavelet)
    sb = max(1, min(depth, round(math.log2(max(SUPER_BRICK // geo.block, 2)))))
    return Plan(shape, dtype.str, geo.block, wavelet, coder, order, np.dtype(work).str, sb, bounded)  # type: ignore[arg-type]


# -- the build -------------------------------------------------------------------------


@dataclasses.dataclass
class TaskResult:
    chunks: list  # (key, payload, error)
    rows: dict  # level -> (raster indices, table rows)
    low: np.ndarray  # the task's top low-pass block (A_s)
    mn: np.ndarray  # min / max of the full-resolution voxels under each A_s voxel
    mx: np.ndarray
    e2: np.ndarray  # squared subtree error of the top node(s)
    sse: float = 0.0
    max_error: float = 0.0
    raw_nbytes: int = 0


def build_task(source: Any, plan: Plan, index: tuple[int, int, int]) -> TaskResult:
    """Build the subtree of the level-``s`` node ``index`` (one super-brick).

    With ``s`` equal to the depth (small volumes) this is the whole tree.
    """
    src = open_source(source)
    geo = plan.geometry
    s = min(plan.sb_levels, geo.depth)
    box = geo.footprint(s, index)
    x = src.read(box)
    if x.shape != tuple(b.stop - b.start for b in box):
        raise FormatError(f"expected a block of shape {box} from the source, found {x.shape}")
    out = TaskResult([], {}, x, x, x, np.zeros((1, 1, 1)), raw_nbytes=x.nbytes)
    if plan.codec is not None:
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            raise FormatError(
                f"an error-bounded octree takes finite voxels, found NaN or Inf in {box}"
            )
        a0 = plan.codec._quantize(x)
    else:
        a0 = x
    origin = tuple(i << s for i in index)  # the super-brick's first level-0 node
    if geo.depth == 0:
        _emit_root_only(plan, a0, x, out)
        return out
    g0 = tuple(math.ceil(n / plan.block) for n in x.shape)
    low, mn, mx, e2 = _build_levels(plan, a0, x, x, np.zeros(g0), 0, s, origin, out, x)
    out.low, out.mn, out.mx, out.e2 = low, mn, mx, e2
    return out


def _emit_root_only(plan: Plan, a0: np.ndarray, x: np.ndarray, out: TaskResult) -> None:
    """A volume no larger than one block: the root is the volume itself."""
    corr = _corrections(plan, a0, x, out)
    lowpass = encode_lowpass(plan, a0.astype(plan.work))
    payload = layout.encode_payload(None, lowpass, corr)
    out.chunks.append((layout.node_key(0, 0), payload, out.max_error))
    row = np.zeros(1, layout.META_DTYPE)
    row["flags"] = layout.PRESENT | layout.SUBTREE_ZERO
    row["maxdev"] = layout.f4_up(out.max_error)
    vals = to_values(plan, a0).astype(np.float64)
    row["vmin"], row["vmax"] = vals.min(), vals.max()
    out.rows[0] = (np.zeros(1, np.int64), row)


def _build_levels(plan, a, mn, mx, e2, l0, l1, origin, out, x0=None):
    """Lift ``a`` (``A_l0`` of a region starting at node ``origin`` of level ``l0``) up
    to level ``l1``, emitting each node's chunk and table row into ``out``."""
    from ..entropy import CODERS
    from ..wavelet import dwt3
    from ..wavelet.sigmap import scan as make_scan

    geo = plan.geometry
    k = plan.block
    work = np.dtype(plan.work)
    unit = plan.codec.step if plan.codec is not None else 1.0
    for level in range(l0 + 1, l1 + 1):
        n = a.shape
        gshape = tuple(math.ceil(v / (2 * k)) for v in n)
        new_a = np.empty(layout.low_shape(n), work)
        mn, mx = _pool(mn, np.minimum), _pool(mx, np.maximum)
        new_e2 = np.zeros(gshape)
        off = tuple(o >> (level - l0) for o in origin)
        ggrid = geo.grid(level)
        rows = np.zeros(math.prod(gshape), layout.META_DTYPE)
        idx = np.zeros(math.prod(gshape), np.int64)
        for j, b in enumerate(itertools.product(*(range(g) for g in gshape))):
            box = tuple(slice(2 * k * i, min(2 * k * (i + 1), v)) for i, v in zip(b, n))
            blk = a[box]
            lv = layout.lift_levels(blk.shape)
            c = dwt3.forward(blk.astype(work), lv, plan.wavelet, overwrite=True)
            ls = layout.low_shape(blk.shape)
            lowbox = tuple(slice(0, v) for v in ls)
            low = c[lowbox].copy()
            c[lowbox] = 0
            dst = tuple(slice(k * i, k * i + v) for i, v in zip(b, ls))
            new_a[dst] = low
            own = layout.detail_energy(c, lv, level, unit)
            kids = e2[tuple(slice(2 * i, 2 * i + 2) for i in b)]
            new_e2[b] = own + float(kids.sum())
            gb = tuple(o + i for o, i in zip(off, b))
            is_root = level == geo.depth
            details = None
            if c.any():
                details = CODERS[plan.coder].encode(c, make_scan(tuple(blk.shape), lv, plan.order))
            corr = None
            if level == 1 and plan.codec is not None:
                corr = _corrections(plan, blk, x0[box], out)
            lowpass = encode_lowpass(plan, low) if is_root else None
            vals = to_values(plan, low)
            row = rows[j : j + 1]
            _node_stats(vals, mn[dst], mx[dst], row)
            row["E"] = layout.f4_up(math.sqrt(new_e2[b]))
            flags = layout.SUBTREE_ZERO if new_e2[b] == 0 else 0
            if details is not None or lowpass is not None or corr is not None:
                flags |= layout.PRESENT
                payload = layout.encode_payload(details, lowpass, corr)
                key = layout.node_key(level, int(np.ravel_multi_index(gb, ggrid)))
                out.chunks.append((key, payload, float(row["maxdev"][0])))
            row["flags"] = flags
            idx[j] = np.ravel_multi_index(gb, ggrid)
        out.rows[level] = (idx, rows)
        a, e2 = new_a, new_e2
    return a, mn, mx, e2


def _corrections(plan: Plan, q: np.ndarray, x: np.ndarray, out: TaskResult) -> bytes | None:
    """Rebuild the voxels as the decoder will, measure them, and store exactly any that
    rounding to the output dtype pushed past the bound (as BoundedCodec does)."""
    if plan.codec is None:
        return None
    from ..volume_codec.lossy import pack_corrections

    rec = plan.codec._reconstruct(q, x.dtype)
    err = np.abs(rec.astype(np.float64) - x.astype(np.float64))
    bad = np.flatnonzero(err > plan.codec.max_error)
    body = None
    if bad.size:
        err.reshape(-1)[bad] = 0.0
        body = pack_corrections(x, bad)
    out.sse += float(np.sum(err * err))
    out.max_error = max(out.max_error, float(err.max(initial=0.0)))
    return body


def _pool(a: np.ndarray, op) -> np.ndarray:
    """2x2x2 min or max (``op``) of ``a``; odd edges pool what is there."""
    pad = [(0, v % 2) for v in a.shape]
    if any(p[1] for p in pad):
        a = np.pad(a, pad, mode="edge")
    z, y, x = (v // 2 for v in a.shape)
    r = a.reshape(z, 2, y, 2, x, 2)
    out = r[:, 0, :, 0, :, 0]
    for dz, dy, dx in itertools.product((0, 1), repeat=3):
        out = op(out, r[:, dz, :, dy, :, dx])
    return out


def _node_stats(values: np.ndarray, mn: np.ndarray, mx: np.ndarray, row: np.ndarray) -> None:
    """Fill ``maxdev``, ``vmin``, ``vmax`` and the 8-bin deviation histogram of a node."""
    hist = np.zeros((layout.HIST_BINS, 2), np.float64)
    v = np.ascontiguousarray(values, np.float64).reshape(-1)
    lo = np.ascontiguousarray(mn, np.float64).reshape(-1)
    hi = np.ascontiguousarray(mx, np.float64).reshape(-1)
    maxdev, vmin, vmax = _node_stats_kernel(v, lo, hi, hist)
    row["maxdev"] = layout.f4_up(maxdev)
    row["vmin"] = np.float32(vmin)
    row["vmax"] = np.float32(vmax)
    row["hist"][0, :, 0] = -layout.f4_up(-hist[:, 0])
    row["hist"][0, :, 1] = layout.f4_up(hist[:, 1])


@one_blas_thread()
def build(
    source: Any,
    target: Any,
    *,
    block: int = layout.DEFAULT_BLOCK,
    wavelet: str = "53",
    coder: str = "arith",
    order: str = "dfs",
    max_error: float | None = None,
    workers: int | None = 1,
    scheduler: Any = None,
    force: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> dict[str, Any]:
    """Build the octree of ``source`` into the ``.vpk`` file ``target``.

    Parameters
    ----------
    source : ndarray, Volume, path spec or SourceSpec
        The ``(z, y, x)`` volume; a path is read box by box (out of core).
    block : int
        ``k``: each node holds ``k^3`` voxels of its level.
    max_error : float, optional
        Every voxel of the full-resolution decode is within this of the input;
        lossless (integer volumes) when None.
    workers : int
        Threads (``None`` or 0: every core); the output does not depend on it.
    scheduler : None, "local", an address or a ``distributed.Client``
        Run the tasks on Dask instead of local threads (same bytes).

    Returns
    -------
    dict
        Sizes, ratio, MB/s, accuracy and the per-level node counts and bytes.
    """
    from ..format.container import Writer

    t0 = time.perf_counter()
    src = open_source(source)
    desc = source if isinstance(source, (str, SourceSpec)) else src
    nworkers = parse_workers(workers)
    if len(src.shape) != 3:
        raise FormatError(f"expected a 3-D (z, y, x) volume for an octree, found shape {src.shape}")
    value_range = None
    if max_error is not None:
        value_range = _value_range(src, desc, nworkers)
    plan = make_plan(
        src.shape,
        src.dtype,
        block=block,
        wavelet=wavelet,
        coder=coder,
        order=order,
        max_error=max_error,
        value_range=value_range,
    )
    geo = plan.geometry
    depth = geo.depth
    s = min(plan.sb_levels, depth)
    gs = geo.grid(s)
    tasks = list(itertools.product(*(range(g) for g in gs)))
    tables = {
        lv: np.zeros(math.prod(geo.grid(lv)), layout.META_DTYPE) for lv in range(1, depth + 1)
    }
    if depth == 0:
        tables[0] = np.zeros(1, layout.META_DTYPE)
    work = np.dtype(plan.work)
    top = np.empty(geo.level_shape(s), work)
    top_mn = np.empty(geo.level_shape(s), src.dtype)
    top_mx = np.empty(geo.level_shape(s), src.dtype)
    top_e2 = np.zeros(gs)
    stats = {"sse": 0.0, "max_error": 0.0, "raw": 0, "payload": 0, "lo": math.inf, "hi": -math.inf}
    with Writer(target, plan.header(src.spacing, src.origin), force=force) as w:

        def take(res: TaskResult, index=None) -> None:
            for key, payload, err in res.chunks:
                w.write(0, key, payload, err)
                stats["payload"] += len(payload)
            for lv, (idx, rows) in res.rows.items():
                tables[lv][idx] = rows
            stats["sse"] += res.sse
            stats["max_error"] = max(stats["max_error"], res.max_error)
            stats["raw"] += res.raw_nbytes
            if res.mn.size:
                stats["lo"] = min(stats["lo"], float(res.mn.min()))
                stats["hi"] = max(stats["hi"], float(res.mx.max()))
            if index is not None:
                box = geo.node_box(s, index)
                top[box], top_mn[box], top_mx[box] = res.low, res.mn, res.mx
                top_e2[index] = res.e2.sum()

        for done, (index, res) in enumerate(
            zip(tasks, _run(desc, plan, tasks, nworkers, scheduler)), 1
        ):
            take(res, index if depth > 0 else None)
            if progress is not None:
                progress(done, len(tasks))
        if depth > s:
            rest = TaskResult([], {}, top, top_mn, top_mx, top_e2)
            _build_levels(plan, top, top_mn, top_mx, top_e2, s, depth, (0, 0, 0), rest)
            take(rest)
        for lv in sorted(tables, reverse=True):
            w.write(0, layout.meta_key(lv), layout.encode_table(tables[lv]))
        summary = _summary(plan, w.entries, tables, stats)
        w.close(summary=summary)
    seconds = time.perf_counter() - t0
    return {
        **summary,
        "seconds": seconds,
        "mb_per_s": throughput(summary["raw_nbytes"], seconds),
        "tasks": len(tasks),
        "workers": nworkers,
        "executor": "threads" if scheduler is None else "dask",
    }


def _run(desc, plan, tasks, nworkers, scheduler):
    """Task results in task order, on threads or on Dask."""
    if scheduler is None:
        yield from ordered_map(lambda t: build_task(desc, plan, t), tasks, nworkers)
        return
    from ..parallel import dask_client

    procs = isinstance(desc, (str, SourceSpec))  # workers open the file themselves
    with dask_client(scheduler, nworkers, procs) as client:
        ahead = max(4, 4 * nworkers)  # bounded look-ahead, as ordered_map
        it = iter(tasks)
        pending = [
            client.submit(build_task, desc, plan, t, pure=False, retries=2)
            for t in itertools.islice(it, ahead)
        ]
        while pending:
            f = pending.pop(0)
            nxt = next(it, None)
            if nxt is not None:
                pending.append(client.submit(build_task, desc, plan, nxt, pure=False, retries=2))
            yield f.result()


def _value_range(src, desc, nworkers) -> tuple[float, float]:
    """Min and max of the volume, read box by box (for the error-bounded quantiser)."""
    dtype = src.dtype
    if dtype.kind in "iu" and dtype.itemsize <= 2:
        info = np.iinfo(dtype)
        return float(info.min), float(info.max)
    step = SUPER_BRICK
    boxes = [
        tuple(slice(i * step, min((i + 1) * step, n)) for i, n in zip(b, src.shape))
        for b in itertools.product(*(range(math.ceil(n / step)) for n in src.shape))
    ]

    def mm(box):
        x = src.read(box)
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            raise FormatError(
                f"an error-bounded octree takes finite voxels, found NaN or Inf in {box}"
            )
        return float(x.min()), float(x.max())

    ranges = list(ordered_map(mm, boxes, nworkers))
    return min(r[0] for r in ranges), max(r[1] for r in ranges)


def _summary(plan, entries, tables, stats) -> dict[str, Any]:
    geo = plan.geometry
    per = {
        lv: {"level": lv, "nodes": math.prod(geo.grid(lv)), "chunks": 0, "nbytes": 0}
        for lv in range(geo.depth + 1)
    }
    for e in entries:
        lv, _ = layout.split_key(e.node)
        if lv in per:
            per[lv]["chunks"] += 1
            per[lv]["nbytes"] += e.nbytes
    for lv, t in tables.items():
        per[lv]["max_deviation"] = float(t["maxdev"].max(initial=0.0))
        per[lv]["E_max"] = float(t["E"].max(initial=0.0))
    nvox = math.prod(plan.shape)
    raw = nvox * np.dtype(plan.dtype).itemsize
    lossless = plan.codec is None
    peak = stats["hi"] - stats["lo"]  # the PSNR peak: the input's value range
    mse = stats["sse"] / max(nvox, 1)
    out = {
        "raw_nbytes": raw,
        "payload_nbytes": stats["payload"],
        "ratio": raw / max(stats["payload"], 1),
        "lossless": lossless,
        "max_error": 0.0 if lossless else stats["max_error"],
        "rmse": math.sqrt(mse),
        "psnr": None if lossless or mse == 0 else psnr_from_sse(mse, 1, max(peak, 1e-300)),
        "value_range": [stats["lo"], stats["hi"]],
        "depth": geo.depth,
        "block": plan.block,
        "levels": [per[lv] for lv in sorted(per)],
    }
    if not lossless:
        out["error_bound"] = plan.codec.max_error
    return out


# --- kernels (numba) ------------------------------------------------------------------


@kernel
def _node_stats_kernel(v, lo, hi, hist):
    """Largest deviation, value range and per-value-bin deviation range of a node.

    Voxel ``i`` of the node stands for full-resolution voxels in ``[lo[i], hi[i]]``; its
    deviation range is ``[lo[i] - v[i], hi[i] - v[i]]``. The node's value range is cut
    into ``hist.shape[0]`` equal bins; each bin keeps the most negative and the most
    positive deviation of the voxels whose value falls in it (seed-004 §7.5, eq. 2.7).
    """
    n = v.size
    vmin = np.inf
    vmax = -np.inf
    for i in range(n):
        vmin = min(vmin, v[i])
        vmax = max(vmax, v[i])
    nb = hist.shape[0]
    width = vmax - vmin
    maxdev = 0.0
    for i in range(n):
        dn = lo[i] - v[i]
        dp = hi[i] - v[i]
        j = 0
        if width > 0:
            j = min(int((v[i] - vmin) / width * nb), nb - 1)
        hist[j, 0] = min(hist[j, 0], dn)
        hist[j, 1] = max(hist[j, 1], dp)
        maxdev = max(maxdev, max(abs(dn), abs(dp)))
    if n == 0:
        vmin = 0.0
        vmax = 0.0
    return maxdev, vmin, vmax
