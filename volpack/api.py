"""Volume <-> ``.vpk``: the library calls behind ``volpack compress``, ``decompress`` and ``info``.

A volume is cut into independent bricks (``volpack.volume_codec.bricks``); each brick is coded by a
brick codec (``volpack.volume_codec.codec``) into one chunk of the container (``volpack.format.container``),
keyed ``(t, node)`` with ``node`` the brick number. Bricks are coded in parallel threads
and written in order, so the file is the same whatever the worker count.
"""

from __future__ import annotations

import io as _io
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any, BinaryIO

import numpy as np

from . import __version__
from .errors import FormatError, OptionError
from .parallel import ordered_map, parse_workers
from .volume import Volume
from .volume_codec import bricks
from .volume_codec.codec import WAVELET_DTYPES, WaveletCodec, ZstdCodec, get_codec, storage_dtype

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]

KIND_VOLUME = "volume"


def make_codec(codec: str = "auto", dtype: Any = None, **options: Any):
    """Choose the brick codec: ``auto`` takes the wavelet codec for the integer dtypes it
    codes exactly and byte-shuffled zstd for floats and 64-bit integers."""
    if codec == "auto":
        codec = "wavelet" if dtype is None or np.dtype(dtype).name in WAVELET_DTYPES else "zstd"
    if codec == "wavelet":
        from .volume_codec.floatwave import FLOAT_WAVELETS

        if options.get("wavelet") in FLOAT_WAVELETS:
            raise OptionError(
                f"the {options['wavelet']} wavelet is a float (lossy) filter for comparison: "
                "add quality=, psnr= or ratio=, or pick 53, 26, haar or 97m for lossless"
            )
        return WaveletCodec(**{k: v for k, v in options.items() if v is not None})
    if codec == "zstd":
        return ZstdCodec()
    raise OptionError(f"expected codec 'auto', 'wavelet' or 'zstd', found {codec!r}")


def compress(
    source: Volume | np.ndarray,
    target: str | BinaryIO,
    *,
    codec: str = "auto",
    wavelet: str | None = None,
    coder: str | None = None,
    order: str | None = None,
    max_levels: int | None = None,
    brick: int | tuple[int, int, int] = bricks.DEFAULT_BRICK,
    max_error: float | None = None,
    rel_error: float | None = None,
    psnr: float | None = None,
    ratio: float | None = None,
    quality: int | None = None,
    threshold: float | None = None,
    fill_value: float | None = None,
    workers: int | None = 1,
    force: bool = False,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Compress a volume into a ``.vpk`` file or stream; return what was measured.

    Lossless unless one of the lossy settings is given (at most one of them):
    ``max_error`` (every valid voxel within this absolute error), ``rel_error`` (the
    same, as a fraction of the value range), ``psnr`` (dB, reached within 0.5 dB),
    ``ratio`` (reached within 5 %), ``quality`` (the method's 255/127/63/31/15 scale) or
    ``threshold`` (coefficients below it, in value units, are dropped). ``fill_value``
    marks voxels that are no data; they, NaN and +-Inf are restored exactly.

    Parameters
    ----------
    source : Volume or ndarray
        ``(z, y, x)`` or ``(t, z, y, x)`` voxels.
    target : str or binary file
        Output path (written atomically; an existing file needs ``force``), ``'-'`` for
        standard output, or an open binary file.
    codec : {"auto", "wavelet", "zstd"}
        ``auto``: the lossless wavelet codec for 8/16/32-bit integers, zstd for the rest.
    wavelet, coder, order, max_levels
        Wavelet codec settings (see :class:`volpack.volume_codec.codec.WaveletCodec`).
    brick : int or (int, int, int)
        Brick size; bricks are coded independently and decoded one by one.
    workers : int or None
        Threads; ``None`` or 0 uses every core. The output does not depend on it.
    progress : callable(done, total), optional
        Called after each brick.

    Returns
    -------
    dict
        ``raw_nbytes``, ``nbytes`` (compressed payload bytes), ``ratio``, ``seconds``,
        ``mb_per_s``, ``bricks``, ``codec``.
    """
    from .format.container import Writer

    vol = source if isinstance(source, Volume) else Volume(np.asarray(source))
    brick_t = bricks.parse_brick(brick)
    nworkers = parse_workers(workers)
    inner = {"wavelet": wavelet, "coder": coder, "order": order, "max_levels": max_levels}
    targets = {
        "max_error": max_error,
        "rel_error": rel_error,
        "psnr": psnr,
        "ratio": ratio,
        "quality": quality,
        "threshold": threshold,
    }
    asked = {k: v for k, v in targets.items() if v is not None}
    if len(asked) > 1:
        raise OptionError(f"expected at most one lossy setting, found {sorted(asked)}")
    if asked:
        from .volume_codec import search as lossy_plan

        c, search = lossy_plan.plan(vol, brick_t, nworkers, asked, fill_value, inner)
    else:
        search = None
        c = make_codec(codec, vol.dtype, **inner)
        if c.codec_id == "wavelet":
            from .volume_codec.codec import check_wavelet_dtype

            check_wavelet_dtype(vol.dtype)
    header = {
        "kind": KIND_VOLUME,
        "volpack": __version__,
        "shape": list(vol.shape),
        "dtype": storage_dtype(vol.dtype).str,
        "spacing": list(vol.spacing),
        "origin": list(vol.origin),
        "brick": list(brick_t),
        "codec": c.get_config(),
        "meta": _jsonable(vol.meta),
    }
    data = vol.data
    frames = data[None] if data.ndim == 3 else data
    tasks = [
        (t, node, sl)
        for t in range(frames.shape[0])
        for node, sl in bricks.iter_bricks(data.shape, brick_t)
    ]
    total = len(tasks)

    def encode(task):
        t, node, sl = task
        return (t, node, *encode_measured(c, np.ascontiguousarray(frames[(t, *sl)])))

    t0 = time.perf_counter()
    nbytes = 0
    worst, sse, nvalid = 0.0, 0.0, 0
    out = "-" if target == "-" else target
    with Writer(_stdout() if out == "-" else out, header, force=force) as w:
        results = ordered_map(encode, tasks, nworkers)
        for done, (t, node, payload, err, s2, n) in enumerate(results, 1):
            w.write(t, node, payload, err)
            nbytes += len(payload)
            worst, sse, nvalid = max(worst, err), sse + s2, nvalid + n
            if progress is not None:
                progress(done, total)
        quality_stats = measured_quality(c, worst, sse, nvalid)
        summary = {
            "raw_nbytes": int(vol.nbytes),
            "payload_nbytes": nbytes,
            "ratio": vol.nbytes / max(nbytes, 1),
            **quality_stats,
        }
        if search is not None:
            summary["search"] = search
        w.close(summary=summary)
    seconds = time.perf_counter() - t0
    return {
        "raw_nbytes": int(vol.nbytes),
        "nbytes": nbytes,
        "ratio": vol.nbytes / max(nbytes, 1),
        "seconds": seconds,
        "mb_per_s": vol.nbytes / 1e6 / max(seconds, 1e-9),
        "bricks": total,
        "workers": nworkers,
        "codec": c.get_config(),
        **quality_stats,
        **({"search": search} if search is not None else {}),
    }


def encode_measured(c, brick: np.ndarray) -> tuple[bytes, float, float, int]:
    """``(payload, max error, squared error sum, valid voxels)`` of one brick."""
    if hasattr(c, "encode_measured"):
        return c.encode_measured(brick)
    return c.encode(brick), 0.0, 0.0, brick.size


def measured_quality(c, worst: float, sse: float, nvalid: int) -> dict[str, Any]:
    """The summary's accuracy fields: lossless or not, max error, RMSE and PSNR."""
    lossless = c.codec_id in ("wavelet", "zstd")
    rng = getattr(c, "value_range", None)
    mse = sse / nvalid if nvalid else 0.0
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        peak2 = np.float64(rng or 1.0) ** 2
        psnr = float("inf") if mse == 0 else float(10 * np.log10(peak2 / mse))
    out = {
        "lossless": lossless,
        "max_error": 0.0 if lossless else float(worst),
        "rmse": float(np.sqrt(mse)) if np.isfinite(mse) else None,
        "psnr": None if lossless or not np.isfinite(psnr) else psnr,
    }
    if not lossless:
        out["mode"] = c.codec_id
        if hasattr(c, "max_error"):
            out["error_bound"] = c.max_error
    return out


def decompress(
    source: str | bytes | BinaryIO,
    *,
    roi: str | tuple[slice, ...] | None = None,
    frame: int | None = None,
    workers: int | None = 1,
    progress: Progress | None = None,
    max_voxels: int = 1 << 34,
) -> Volume:
    """Decode a ``.vpk`` volume, or only the region ``roi`` of it (reading only the
    bricks that region touches).

    ``roi`` is ``"z0:z1,y0:y1,x0:x1"`` or three slices; ``frame`` picks one time step of
    an animation. The result keeps dtype, spacing and the origin of the region.
    """
    from .format.container import Reader

    nworkers = parse_workers(workers)
    src = _stdin() if source == "-" else source
    with Reader(src) as r:
        if r.header.get("kind") == "animation":
            from .animation.stream import decompress as decompress_animation

            return decompress_animation(r, roi=roi, frame=frame, progress=progress)
        hdr = _check_volume_header(r.header, max_voxels)
        shape = tuple(hdr["shape"])
        dtype = np.dtype(hdr["dtype"]).newbyteorder("=")
        brick_t = tuple(hdr["brick"])
        c = get_codec(hdr["codec"])
        spatial = shape[-3:]
        nt = shape[0] if len(shape) == 4 else 1
        if frame is not None and not 0 <= frame < nt:
            raise FormatError(f"expected a frame in 0..{nt - 1}, found {frame}")
        region = _parse_roi(roi, spatial)
        origin = tuple(o + s.start * d for o, s, d in zip(hdr["origin"], region, hdr["spacing"]))
        rshape = tuple(s.stop - s.start for s in region)
        times = [frame] if frame is not None else list(range(nt))
        out = np.empty((len(times), *rshape), dtype=dtype)
        nodes = bricks.bricks_in_roi(spatial, brick_t, region)
        tasks = [(i, t, node) for i, t in enumerate(times) for node in nodes]
        seekable = r.seekable
        if not seekable:
            wanted = {(t, n) for _, t, n in tasks}
            cache = {(t, n): p for t, n, p in r if (t, n) in wanted}

        lock = threading.Lock()

        def fetch(task):
            i, t, node = task
            if seekable:
                with lock:  # one file handle: reads are serial, decoding is not
                    payload = r.read(t, node)
            else:
                payload = cache.pop((t, node), None)
            if payload is None:
                raise FormatError(f"stream has no chunk for frame {t}, brick {node}")
            sl = bricks.brick_slices(spatial, brick_t, node)
            bshape = tuple(s.stop - s.start for s in sl)
            return i, sl, c.decode(payload, bshape, dtype)

        for done, (i, sl, b) in enumerate(ordered_map(fetch, tasks, nworkers), 1):
            src_sl, dst_sl = _intersect(sl, region)
            out[(i, *dst_sl)] = b[src_sl]
            if progress is not None:
                progress(done, len(tasks))
    data = out[0] if (len(shape) == 3 or frame is not None) else out
    return Volume(
        data, spacing=tuple(hdr["spacing"]), origin=origin, meta=dict(hdr.get("meta") or {})
    )


def compress_array(array: np.ndarray | Volume, **options: Any) -> bytes:
    """Compress an array (or a Volume) to ``.vpk`` bytes (options as for :func:`compress`)."""
    buf = _io.BytesIO()
    compress(array if isinstance(array, Volume) else np.asarray(array), buf, **options)
    return buf.getvalue()


def decompress_array(blob: bytes, **options: Any) -> np.ndarray:
    """Decode ``.vpk`` bytes made by :func:`compress_array` back to the array."""
    return decompress(bytes(blob), **options).data


def info(source: str | BinaryIO, **read_options: Any) -> dict[str, Any]:
    """Describe a ``.vpk`` file (a path, or a seekable binary file such as
    :func:`volpack.format.container.spool` of a pipe) or any volume volpack reads, as plain
    JSON types."""
    from . import io as vio
    from .format import container

    if not isinstance(source, str) or (source != "-" and _looks_vpk(source)):
        with container.Reader(source) as r:
            hdr = r.header
            entries = r.entries
            sizes = np.array([e.nbytes for e in entries], dtype=np.int64)
            errors = np.array([e.error for e in entries], dtype=np.float64)
            raw = _raw_nbytes(hdr)
            file_size = container.source_size(source)
            return {
                "format": "vpk",
                "path": source if isinstance(source, str) else "-",
                "header": hdr,
                "summary": r.summary,
                "chunks": len(entries),
                "file_nbytes": file_size,
                "payload_nbytes": int(sizes.sum()),
                "raw_nbytes": raw,
                "ratio": raw / max(file_size, 1),
                "chunk_nbytes": {
                    "min": int(sizes.min()) if sizes.size else 0,
                    "max": int(sizes.max(initial=0)),
                    "mean": float(sizes.mean()) if sizes.size else 0.0,
                },
                "max_error": float(errors.max(initial=0.0)),
                "entries": [
                    {
                        "t": e.t,
                        "node": e.node,
                        "offset": e.offset,
                        "nbytes": e.nbytes,
                        "error": e.error,
                    }
                    for e in entries
                ],
            }
    vol = vio.read_volume(source, **read_options)
    d = vol.describe()
    d["format"] = vio.detect_format(vio.parse_spec(source)[0]) if source != "-" else "npy"
    d["path"] = source
    return d


# -- helpers -------------------------------------------------------------------------


def _looks_vpk(path: str) -> bool:
    from .format.container import is_vpk

    try:
        with open(path, "rb") as f:
            return is_vpk(f.read(16))
    except OSError:
        return False


def _raw_nbytes(hdr: dict) -> int:
    """Bytes of the decoded volume a header describes (0 for kinds without a shape)."""
    from .format import header as h

    if "shape" not in hdr:
        return 0
    shape = h.shape(hdr["shape"], "shape", (3, 4), 1 << 62)
    return math.prod(shape) * h.dtype(hdr.get("dtype")).itemsize


def _check_volume_header(hdr: dict, max_voxels: int) -> dict:
    from .format import header as h

    need = ("shape", "dtype", "spacing", "origin", "brick", "codec")
    if hdr.get("kind") != KIND_VOLUME or any(k not in hdr for k in need):
        raise FormatError(f"expected a volpack volume header with {need}, found keys {sorted(hdr)}")
    shape = h.shape(hdr["shape"], "shape", (3, 4), max_voxels)
    h.dtype(hdr["dtype"])
    try:
        brick_t = bricks.parse_brick(hdr["brick"])
    except (TypeError, ValueError, OverflowError) as e:
        raise FormatError(f"bad volume header: {e}") from None
    hdr = dict(hdr)
    hdr["spacing"] = h.vector(hdr["spacing"], "spacing", 3, positive=True)
    hdr["origin"] = h.vector(hdr["origin"], "origin", 3)
    if not isinstance(hdr.get("meta", {}), dict):
        raise FormatError(f"expected meta as a JSON object, found {hdr['meta']!r:.60}")
    get_codec(hdr["codec"])
    hdr["shape"], hdr["brick"] = shape, brick_t
    return hdr


def _parse_roi(roi, shape: tuple[int, ...]) -> tuple[slice, slice, slice]:
    if roi is None:
        return tuple(slice(0, n) for n in shape)  # type: ignore[return-value]
    if isinstance(roi, str):
        from .prep import parse_ranges

        roi = parse_ranges(roi, shape)
    out = []
    for s, n in zip(roi, shape):
        start, stop, step = s.indices(n)
        if step != 1 or stop <= start:
            raise FormatError(
                f"expected a non-empty region with step 1 inside {shape}, found {roi}"
            )
        out.append(slice(start, stop))
    if len(out) != 3:
        raise FormatError(f"expected a region of three ranges (z, y, x), found {roi}")
    return tuple(out)  # type: ignore[return-value]


def _intersect(brick_sl, region):
    src, dst = [], []
    for b, r in zip(brick_sl, region):
        lo, hi = max(b.start, r.start), min(b.stop, r.stop)
        src.append(slice(lo - b.start, hi - b.start))
        dst.append(slice(lo - r.start, hi - r.start))
    return tuple(src), tuple(dst)


def _jsonable(meta: dict) -> dict:
    import json

    try:
        json.dumps(meta)
        return meta
    except TypeError:
        return json.loads(
            json.dumps(meta, default=lambda o: o.tolist() if hasattr(o, "tolist") else str(o))
        )


def _stdout():
    import sys

    return sys.stdout.buffer


def _stdin():
    from .format.container import stdin

    return stdin()
