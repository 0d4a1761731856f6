"""The volume stream kind: a volume <-> ``.vpk`` of kind ``volume``.

A volume is cut into independent bricks (:mod:`volpack.volume_codec.bricks`); each brick is
coded by a brick codec (:mod:`volpack.volume_codec.codec`, or a lossy one chosen by
:mod:`volpack.volume_codec.search`) into one chunk of the container
(:mod:`volpack.format.container`), keyed ``(t, node)`` with ``node`` the brick number.
Bricks are coded in parallel threads and written in order, so the file is the same
whatever the worker count. Like every stream kind (:mod:`volpack.kinds`) it provides
:func:`compress`, :func:`open` (a reader), :func:`decompress`, :func:`check_header` and
:func:`info`.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any, BinaryIO

import numpy as np

from .. import __version__
from ..errors import FormatError, OptionError
from ..format.checked import CheckedReader
from ..format.describe import describe
from ..format.streams import stdin
from ..jsonsafe import jsonable
from ..metrics import psnr_from_sse, throughput
from ..parallel import (
    auto_workers,
    completed_map,
    one_blas_thread,
    ordered_map,
    parse_workers,
)
from ..volume import Volume, declared_fill, require_voxels
from . import bricks
from . import interleave as il
from . import tuples as tp
from .channels import CHANNELS_LAST, looks_channels_first, looks_channels_last
from .codec import WaveletCodec, ZstdCodec
from .protocol import storage_dtype
from .registry import get_codec

log = logging.getLogger(__name__)

Progress = Callable[[int, int], None]

KIND = "volume"
DEFAULT_MAX_VOXELS = 1 << 34
LOSSY_KEYS = ("max_error", "rel_error", "psnr", "ratio", "quality", "threshold")


def make_codec(codec: str = "auto", dtype: Any = None, **options: Any):
    """Choose the brick codec: ``auto`` takes the lossless codec (per brick the wavelet,
    3-D prediction, labels or float prediction) for the integers, floats and masks it
    codes exactly (64-bit integers: zstd, palettes and labels; bool: as uint8), and
    byte-shuffled zstd for the rest."""
    from .lossless import LOSSLESS_DTYPES

    if codec == "auto":
        known = dtype is None or np.dtype(dtype).name in LOSSLESS_DTYPES
        codec = "lossless" if known else "zstd"
    if codec in ("lossless", "wavelet"):
        from .floatwave import FLOAT_WAVELETS

        if options.get("wavelet") in FLOAT_WAVELETS:
            raise OptionError(
                f"the {options['wavelet']} wavelet is a float (lossy) filter for comparison: "
                "add quality=, psnr= or ratio=, or pick 53, 26, haar or 97m for lossless"
            )
    if codec == "lossless":
        from .lossless import LosslessCodec

        return LosslessCodec(**{k: v for k, v in options.items() if v is not None})
    if codec == "wavelet":
        return WaveletCodec(**{k: v for k, v in options.items() if v is not None})
    if codec == "zstd":
        return ZstdCodec()
    if codec == "fast":
        from .fast import FastCodec

        return FastCodec(**{k: options.get(k, True) for k in ("runs", "rows", "zstd")})
    raise OptionError(
        f"expected codec 'auto', 'lossless', 'fast', 'wavelet' or 'zstd', found {codec!r}"
    )


def _zero_bound(asked: dict[str, Any]) -> bool:
    """Whether ``asked`` is ``max_error`` or ``rel_error`` of 0 (of any dtype): every
    voxel exact."""
    if len(asked) != 1:
        return False
    ((what, target),) = asked.items()
    try:
        return what in ("max_error", "rel_error") and float(target) == 0.0
    except (TypeError, ValueError):
        return False


# Memory of one brick's encode, per voxel of the brick, with room to spare: a second
# worker on the lossy selection's 128^3 float32 bricks added about 290 MB of resident
# memory (140 B a voxel; 430 before session 30's mem30), the lossless coders less. A
# worker count left to volpack keeps within half the memory at this rate.
ENCODE_BYTES_PER_VOXEL = 256


def _encode_workers(
    workers: int | None, shape: tuple[int, ...], brick: tuple[int, int, int]
) -> int:
    """The thread count of an encode: as asked, or for ``None`` and 0 every core, capped
    by the bricks there are and by the memory their encodes need at once."""
    if workers is not None and workers != 0:
        return parse_workers(workers)
    frames = int(np.prod(shape[:-3], dtype=np.int64))
    tasks = frames * int(np.prod(bricks.grid_shape(shape[-3:], brick), dtype=np.int64))
    voxels = int(np.prod([min(b, n) for b, n in zip(brick, shape[-3:])], dtype=np.int64))
    return auto_workers(tasks, voxels * ENCODE_BYTES_PER_VOXEL)


@one_blas_thread()
def compress(
    source: Volume | np.ndarray | str,
    target: str | BinaryIO,
    *,
    codec: str = "auto",
    wavelet: str | None = None,
    coder: str | None = None,
    order: str | None = None,
    max_levels: int | None = None,
    tools: str | None = None,
    predict_version: int | None = None,
    runs: bool | None = None,
    rows: bool | None = None,
    zstd: bool | None = None,
    brick: int | tuple[int, int, int] | None = None,
    max_error: float | None = None,
    rel_error: float | None = None,
    psnr: float | None = None,
    ratio: float | None = None,
    quality: int | None = None,
    threshold: float | None = None,
    fill_value: float | None = None,
    effort: str = "default",
    interleave: bool | None = None,
    channels_last: bool | None = None,
    tuples: bool | None = None,
    workers: int | None = 1,
    force: bool = False,
    progress: Progress | None = None,
    read_options: dict | None = None,
) -> dict[str, Any]:
    """Compress a volume into a ``.vpk`` file or stream; return what was measured.

    Lossless unless one of the lossy settings is given (at most one of them):
    ``max_error`` (every valid voxel within this absolute error), ``rel_error`` (the
    same, as a fraction of the value range), ``psnr`` (dB, reached within 0.5 dB),
    ``ratio`` (the file's, ``file_ratio``, reached within 5 %; where no setting reaches a
    PSNR or ratio, the nearest above it is kept and a warning logged), ``quality`` (the
    method's 255/127/63/31/15 scale) or
    ``threshold`` (coefficients below it, in value units, are dropped). ``fill_value``
    marks voxels that are no data; they, NaN and +-Inf are restored exactly. Under a lossy
    setting it defaults to the fill a netCDF source declares (:func:`declared_fill`).

    Parameters
    ----------
    source : Volume, ndarray or str
        ``(z, y, x)`` or ``(t, z, y, x)`` voxels, or a volume file spec
        (:func:`volpack.io.read_volume`, with ``read_options``) read after ``target``
        has been checked.
    target : str or binary file
        Output path (written atomically; an existing file needs ``force``), ``'-'`` for
        standard output, or an open binary file.
    codec : {"auto", "lossless", "fast", "wavelet", "zstd"}
        ``auto``: the ``lossless`` codec (per brick the wavelet, 3-D prediction, labels
        or float prediction) for integers and floats (64-bit integers: byte-shuffled zstd,
        palettes and labels per brick).
        ``fast``: lossless, decoding several times faster at a lower ratio
        (:class:`volpack.volume_codec.fast.FastCodec`).
    wavelet, coder, order, max_levels
        Wavelet codec settings (see :class:`volpack.volume_codec.codec.WaveletCodec`).
    tools : {"auto", "wavelet", "predict"}, optional
        The lossless codec's tools (:class:`volpack.volume_codec.lossless.LosslessCodec`).
    predict_version : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10}, optional
        The lossless codec's predictive stream: 9 (as 8, and integers also averaged
        with a predictor refitted along every row, :mod:`.localfit`: what
        ``effort='max'`` picks), 8 (the default: as 7, and integers also
        with the mixed estimates of :mod:`.residmix`), 7 (as 6, and integers also
        with the texture bias of :mod:`.predictfit`), 6 (as 5, and float32 and
        float64 also by a predictor fitted per brick, :mod:`.floatfit`), 5 (as 4, and
        integers also with the low-value models of :mod:`.predictfit`), 4 (as 3, and floats also by
        a blend of predictors with copies and a fill value), 3 (as 2, and floats by
        Lorenzo or lattice prediction), 2 or 1 (as files written before, byte for byte).
    runs : bool, optional
        The fast codec's run mode: on (the default) or off (as files written before it,
        byte for byte).
    rows : bool, optional
        The fast codec's row kinds (copies of the row or slice above; with the run
        mode): on (the default) or off (as files written before them, byte for byte).
    zstd : bool, optional
        The fast codec's zstd bricks (mode 3, where byte-shuffled zstd is about as short
        and decodes far faster: label maps): on (the default) or off (as files written
        before them, byte for byte).
    effort : {"default", "fast", "max"}
        The error-bounded encoder's (``max_error``, ``rel_error``, or ``psnr``/``ratio``
        on floats): ``default`` makes every coding of a brick and keeps the shortest;
        ``fast`` makes one or two (the quantised voxels by the fast lossless codec;
        floats: also the interpolation path), faster to encode and 2-4x faster to
        decode, at some ratio; ``max`` keeps the shortest coding
        whatever its decoding speed, the quantised voxels also by the lossless codec's
        local fit. The bound holds either way. Lossless
        (the ``auto`` or ``lossless`` codec): ``max`` also tries, on integer bricks,
        the prediction refitted along every row (``predict_version=9``): 1-9 % fewer
        bytes on scans and more on some label maps, decoding 4-10x slower; and on
        float32/64 bricks a box of up to 10 x 10 rows of fitted weights
        (``predict_version=10``): up to 14 % fewer bytes on smooth fields, decoding
        about 2x slower.
    interleave : bool, optional
        A ``(t, z, y, x)`` series: store its slices in ``(z, t)`` order, so that the
        codecs predict each voxel also from the previous time step (:mod:`.interleave`).
        ``None`` (the default) does where a sample of the series codes shorter so at the
        setting asked (a PSNR or ratio target: the setting searched on the time steps,
        then searched again on the stored volume); ``False`` codes each time step alone,
        as before.
    channels_last : bool, optional
        A 4-D ``(z, y, x, c)`` volume of a few channels (RGB, fluorescence channels):
        store it as the series of its channels ``(c, z, y, x)`` (each channel a time
        step, ``interleave`` then applying to them), header ``"channels": "last"``;
        decoded as ``(z, y, x, c)`` again. ``None`` (the default) does where the last axis has at most
        :data:`.channels.MAX_CHANNELS` voxels and every other more; ``False`` takes the 4-D
        volume as ``(t, z, y, x)``, as before.
    tuples : bool, optional
        A 4-D integer volume of a few channels, last (as ``channels_last`` takes them)
        or first (``(c, z, y, x)``, at most :data:`.channels.MAX_CHANNELS`), coded
        exactly: store it as the palette of its distinct voxel tuples and the 3-D
        volume of each voxel's index into it (:mod:`.tuples`: a scan through a colour
        map, labels in colours), header ``"channels": {"axis": ..., "tuples": K}``.
        ``None`` (the default) does where the volume has at most 65,536 tuples (and
        8 voxels a tuple) and a sample codes shorter so; ``True`` wherever it has such
        a palette; ``False`` never, as before. Never with ``interleave`` given or a
        lossy setting (those keep the channels).
    brick : int or (int, int, int), optional
        Brick size (of the stored 3-D volume when interleaved); bricks are coded
        independently and decoded one by one. Default
        :func:`volpack.volume_codec.bricks.default_brick`: 64, but a float volume under an
        error bound (or a PSNR or ratio target) is one brick up to 4M voxels, else 128^3,
        and a float volume coded exactly by the default codec takes 128^3, as does an
        integer volume of at most 2^21 voxels.
    workers : int or None
        Threads; ``None`` or 0 uses every core, but no more than there are bricks and no
        more than half the memory holds (:data:`ENCODE_BYTES_PER_VOXEL` a brick voxel).
        The output does not depend on it.
    progress : callable(done, total), optional
        Called after each brick.

    Returns
    -------
    dict
        ``raw_nbytes``, ``nbytes`` (compressed payload bytes), ``ratio``, ``file_nbytes``
        and ``file_ratio`` (the whole stream, as :func:`volpack.api.info` reports),
        ``seconds`` and ``mb_per_s`` (the coding, a setting search included), ``bricks``,
        ``codec``, ``layout`` (``"interleaved"``) for a series stored interleaved, and
        ``channels`` (``"last"``) for a volume stored as the series of its channels,
        ``tuples`` (K) and ``tuple_order`` for one stored as a tuple palette.
    """
    from ..format.container import Writer

    if isinstance(source, str):
        from .. import io as vio
        from ..format.atomic import check_output

        check_output(target, force=force, inputs=(vio.parse_spec(source)[0],))
        source = vio.read_volume(source, **(read_options or {}))
    vol = source if isinstance(source, Volume) else Volume(np.asarray(source))
    require_voxels(vol.data.shape)
    t0 = time.perf_counter()  # the setting search counts: the speed is the whole coding's
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
        found = ", ".join(f"{k}={v}" for k, v in sorted(asked.items()))
        raise OptionError(f"expected at most one lossy setting, found {found}")
    if _zero_bound(asked):  # exact: the lossless coding, never longer than a bound's
        log.info("an error bound of 0: coded losslessly")
        asked = {}
        if effort == "fast":  # the fast lossless codec, as the fast bounded one uses
            codec, effort = ("fast" if codec == "auto" else codec), "default"
    if asked and fill_value is None:
        fill_value = declared_fill(vol)
    known_range = None  # the valid voxels' range, once read
    if asked and codec in ("auto", "lossless") and not any(inner.values()):
        from .search import exact_bound

        exact, known_range = exact_bound(vol, asked, fill_value, effort)
        if exact:
            log.info("an error bound only exact coding meets: coded exactly")
            asked = {}
    data = vol.data
    if interleave and data.ndim != 4:
        raise OptionError(f"interleave: expected a 4-D (t, z, y, x) series, found {data.ndim} axes")
    bounded = bool(asked) and not ({"quality", "threshold"} & set(asked))
    channels = channels_last is not False and data.ndim == 4
    channels = channels and (channels_last or looks_channels_last(data.shape))
    if channels:  # the channels become the time steps of a series
        data = np.ascontiguousarray(np.moveaxis(data, -1, 0))
        log.info("the last axis taken as %d channels: stored as %s", data.shape[0], data.shape)
    elif channels_last:
        raise OptionError(f"channels_last: a 4-D (z, y, x, c) volume, found {data.ndim} axes")
    # what a PSNR or ratio target is searched on: the series as stored
    planned = Volume(data, vol.spacing, vol.origin) if channels else vol

    def brick_of(shape: tuple[int, ...]) -> tuple[int, int, int]:
        if brick is not None:
            return bricks.parse_brick(brick)
        return bricks.default_brick(shape, vol.dtype, bounded, codec, bool(asked))

    brick_t = brick_of(data.shape)
    nworkers = _encode_workers(workers, data.shape, brick_t)
    for name, value in (("runs", runs), ("rows", rows), ("zstd", zstd)):
        if value is not None and (codec != "fast" or asked):
            raise OptionError(
                f"{name}: a setting of the lossless fast codec, found codec {codec!r}"
            )
    if asked:
        from . import search as lossy_plan

        c, search = lossy_plan.plan(
            planned, brick_t, nworkers, asked, fill_value, inner, effort, known_range
        )
    else:
        if effort == "max":
            from .lossless import BOX_VERSION

            if codec not in ("auto", "lossless") or predict_version not in (None, BOX_VERSION):
                raise OptionError(
                    f"effort='max' is the lossless codec's predict_version={BOX_VERSION}; "
                    f"found codec={codec!r}" + (
                        f", predict_version={predict_version}" if predict_version is not None else ""
                    )
                )  # fmt: skip
            predict_version = BOX_VERSION
        elif effort != "default":
            raise OptionError(
                f"effort={effort!r} applies to error-bounded lossy coding (max_error, "
                "rel_error, psnr, ratio); for a faster lossless stream use codec='fast'"
            )
        search = None
        extra = {
            "tools": tools,
            "predict_version": predict_version,
            "runs": runs,
            "rows": rows,
            "zstd": zstd,
        }
        c = make_codec(
            codec, vol.dtype, **inner, **{k: v for k, v in extra.items() if v is not None}
        )
        if c.codec_id == "wavelet":
            from .codec import check_wavelet_dtype

            check_wavelet_dtype(vol.dtype)
        elif c.codec_id in ("lossless", "fast"):
            from .lossless import check_dtype

            check_dtype(vol.dtype)
    layout = None

    def size_of(v: np.ndarray) -> int:  # bytes of a 3-D volume's bricks, as coded below
        return sum(
            len(c.encode_measured(np.ascontiguousarray(v[sl]))[0])
            for _, sl in bricks.iter_bricks(v.shape, brick_of(v.shape))
        )

    palette, pays = None, None  # a tuple palette (.tuples), the sample's interleave answer
    first = not channels and looks_channels_first(data.shape)
    if tuples is not False and (channels or first) and c.lossless and interleave is None:
        palette, pays = tp.plan(data, size_of, force=bool(tuples))
        if palette is not None:
            data = palette.index
            brick_t = brick_of(data.shape)
            nworkers = _encode_workers(workers, data.shape, brick_t)
            log.info(
                "stored as a palette of %d tuples (%s order) and an index volume: about "
                "%d bytes against %d as channels", len(palette.tuples), palette.order,
                palette.estimate, palette.channels_estimate,
            )  # fmt: skip
    if data.ndim == 4 and interleave is not False:
        if interleave or (pays if pays is not None else il.pays(data, size_of)):
            layout, data = il.LAYOUT, il.fold(data)
            brick_t = brick_of(data.shape)
            nworkers = _encode_workers(workers, data.shape, brick_t)
            log.info("time steps interleaved: stored as %s", "x".join(map(str, data.shape)))
            if search is not None:
                # A PSNR or ratio target: the setting found on the time steps codes the
                # stored volume to another PSNR and size; searched again from there.
                c, search = lossy_plan.plan(
                    Volume(data, vol.spacing, vol.origin), brick_t, nworkers, asked,
                    fill_value, inner, effort, known_range, start=_searched(search),
                )  # fmt: skip
    header = {
        "kind": KIND,
        "volpack": __version__,
        "shape": list(vol.shape),
        "dtype": storage_dtype(vol.dtype).str,
        "spacing": list(vol.spacing),
        "origin": list(vol.origin),
        "brick": list(brick_t),
        "codec": c.get_config(),
        **({"layout": layout} if layout else {}),
        **({"channels": CHANNELS_LAST} if channels and palette is None else {}),
        **(
            {"channels": {"axis": tp.AXES[first], "tuples": len(palette.tuples)}}
            if palette is not None
            else {}
        ),
        "meta": jsonable(vol.meta),
    }
    frames = data[None] if data.ndim == 3 else data
    tasks = [
        (t, node, sl)
        for t in range(frames.shape[0])
        for node, sl in bricks.iter_bricks(data.shape, brick_t)
    ]
    total = len(tasks)

    def encode(task):
        t, node, sl = task
        return (t, node, *c.encode_measured(np.ascontiguousarray(frames[(t, *sl)])))

    nbytes = 0
    worst, sse, nvalid = 0.0, 0.0, 0
    tools_used: dict[str, int] = {}  # lossless codec: bricks per tool chosen
    tool_of = getattr(c, "describe", None)
    with Writer(_stdout() if target == "-" else target, header, force=force) as w:
        if palette is not None:  # the palette first (chunk (1, 0)), then the index bricks
            chunk = tp.pack(palette.tuples)
            w.write(1, 0, chunk)
            nbytes += len(chunk)
        results = ordered_map(encode, tasks, nworkers)
        for done, (t, node, payload, err, s2, n) in enumerate(results, 1):
            w.write(t, node, payload, err)
            if tool_of is not None:
                tool = tool_of(payload)
                tools_used[tool] = tools_used.get(tool, 0) + 1
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
        _six_digits(summary, ("ratio", "rmse", "psnr"))
        if search is not None:
            # what `volpack info` shows (target, value, the setting, what it reached); the
            # steps of the search (300-500 B, a tenth of a small field's file) are the
            # caller's alone
            summary["search"] = {k: v for k, v in search.items() if k != "steps"}
            _six_digits(summary["search"], ("reached",))
            if not math.isfinite(summary["search"].get("reached", 0.0)):
                summary["search"]["reached"] = None  # coded exactly: no PSNR (as "psnr")
        if tools_used:
            summary["tools"] = dict(sorted(tools_used.items()))
        w.close(summary=summary)
    seconds = time.perf_counter() - t0
    return {
        "raw_nbytes": int(vol.nbytes),
        "nbytes": nbytes,
        "ratio": vol.nbytes / max(nbytes, 1),
        "file_nbytes": w.nbytes,  # header and index included, as `volpack info` counts
        "file_ratio": vol.nbytes / max(w.nbytes, 1),
        "seconds": seconds,
        "mb_per_s": throughput(vol.nbytes, seconds),
        "bricks": total,
        **({"layout": layout} if layout else {}),
        **({"channels": CHANNELS_LAST} if channels else {}),
        **(
            {"tuples": len(palette.tuples), "tuple_order": palette.order}
            if palette is not None
            else {}
        ),
        "workers": nworkers,
        "codec": c.get_config(),
        **quality_stats,
        **({"search": search} if search is not None else {}),
    }


def _searched(record: dict[str, Any]) -> float | None:
    """The setting a search record ended on, as a start for a search of the same kind
    (none for a Tucker codec's step: the search begins with the bounded codec's)."""
    if record.get("codec") == "tucker":
        return None
    return record.get("error_bound", record.get("step"))


def stored_series_shape(hdr: dict) -> tuple[int, ...]:
    """The shape a volume stream stores: its ``shape``, but ``(c, z, y, x)`` for a
    ``(z, y, x, c)`` volume stored as the series of its channels (or as a tuple palette:
    the shape its channels have)."""
    shape = tuple(hdr["shape"])
    tup = hdr.get("channels")
    if tup == CHANNELS_LAST or (isinstance(tup, dict) and tup.get("axis") == "last"):
        return (shape[-1], *shape[:-1])
    return shape


def _six_digits(d: dict[str, Any], keys: tuple[str, ...]) -> None:
    """Measured figures of a summary to 6 significant digits (as `volpack info` shows
    them): the 17 of a float64 cost ~30 bytes of a small file. Bounds stay exact."""
    for key in keys:
        if isinstance(d.get(key), float):
            d[key] = float(f"{d[key]:.6g}")


def measured_quality(c, worst: float, sse: float, nvalid: int) -> dict[str, Any]:
    """The summary's accuracy fields: lossless or not, max error, RMSE and PSNR."""
    lossless = c.lossless
    rng = getattr(c, "value_range", None)
    mse = sse / nvalid if nvalid else 0.0
    if mse == 0.0 and worst > 0.0:  # errors near 1e-300 square to 0 (as near 1e300 to inf)
        mse = math.nan
    psnr = psnr_from_sse(sse, nvalid, rng or 1.0)
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


class VolumeReader(CheckedReader):
    """A volume ``.vpk`` opened for reading: the checked :attr:`header`, and
    :meth:`read` of the whole volume, one frame or a region (only the bricks it touches)."""

    def __init__(self, source: Any, *, max_voxels: int = DEFAULT_MAX_VOXELS) -> None:
        super().__init__(source, check_header, max_voxels)

    def read(
        self,
        *,
        roi: str | tuple[slice, ...] | None = None,
        frame: int | None = None,
        workers: int | None = 1,
        progress: Progress | None = None,
    ) -> Volume:
        """The volume, the time step ``frame`` or the region ``roi`` (``"z0:z1,y0:y1,x0:x1"``
        or three slices), keeping dtype, spacing and the origin of the region. (A series
        stored interleaved decodes every time step of the region's slices, also for one
        ``frame``; one stored as a tuple palette decodes its index volume once, a
        ``frame`` then being a channel.)"""
        r, hdr = self._r, self.header
        nworkers = parse_workers(workers)
        shape = stored_series_shape(hdr)  # (a channel is a time step here)
        dtype = np.dtype(hdr["dtype"]).newbyteorder("=")
        tup = hdr["channels"] if isinstance(hdr.get("channels"), dict) else None
        brick_t = tuple(hdr["brick"])
        c = get_codec(hdr["codec"])
        spatial = shape[-3:]
        nt = shape[0] if len(shape) == 4 else 1
        if frame is not None and not 0 <= frame < nt:
            raise FormatError(f"expected a frame in 0..{nt - 1}, found {frame}")
        seekable = r.seekable
        region = parse_roi(roi, spatial)
        times = [frame] if frame is not None else list(range(nt))
        # what is stored: one 3-D volume per time step, or the series interleaved
        # (slice z * nt + t; the region's slices are whole groups of nt)
        interleaved = hdr.get("layout") == il.LAYOUT
        if interleaved:
            stored, keys = il.stored_shape(shape), [0]
            z = region[0]
            sregion = (slice(z.start * nt, z.stop * nt), *region[1:])
        elif tup is not None:  # one 3-D volume of indices into the tuples (chunk (1, 0))
            stored, keys, sregion = spatial, [0], region
        else:
            stored, keys, sregion = spatial, times, region
        nchunks = (1 if interleaved or tup else nt) * math.prod(bricks.grid_shape(stored, brick_t))
        nchunks += 1 if tup else 0
        if not seekable:  # a pipe: the payloads are read (and counted) before anything else
            cache = {(t, n): p for t, n, p in r}
        if len(r if seekable else cache) != nchunks:
            # every writer stores every brick; a shape or brick changed by damage shows here,
            # before a list of a million bricks or an output of gigabytes is made
            raise FormatError(
                f"expected {nchunks} chunks for shape {list(shape)} in bricks of "
                f"{list(brick_t)}, found {len(r if seekable else cache)}"
            )
        origin = tuple(o + s.start * d for o, s, d in zip(hdr["origin"], region, hdr["spacing"]))
        if tup is not None:
            key = (1, 0)
            payload = r.read(*key) if seekable else cache.pop(key, None)
            if payload is None:
                raise FormatError("stream has no tuple palette chunk (t=1, node=0)")
            palette = tp.unpack(payload, tup["tuples"], nt, dtype)
        dtype_out = tp.index_dtype(tup["tuples"]) if tup else dtype
        out = np.empty((len(keys), *(s.stop - s.start for s in sregion)), dtype=dtype_out)
        nodes = bricks.bricks_in_roi(stored, brick_t, sregion)
        tasks = [(i, t, node) for i, t in enumerate(keys) for node in nodes]
        if workers is None or workers == 0:  # every core, one brick each at most
            nworkers = auto_workers(len(tasks))
        if nworkers > 1:  # largest payloads first: the small ones left fill the gaps at the
            # end, so the workers finish together (each brick writes its own part of
            # ``out``: the output does not depend on the order)
            if seekable:
                size = {(e.t, e.node): e.nbytes for e in r.entries}
            else:
                size = {k: len(p) for k, p in cache.items()}
            tasks.sort(key=lambda task: -size.get(task[1:], 0))

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
            sl = bricks.brick_slices(stored, brick_t, node)
            bshape = tuple(s.stop - s.start for s in sl)
            src_sl, dst_sl = _intersect(sl, sregion)
            if all(s.stop - s.start == n for s, n in zip(src_sl, bshape)):
                c.decode_into(payload, out[(i, *dst_sl)])  # the whole brick: in place
                return None
            return (i, *dst_sl), c.decode(payload, bshape, dtype_out)[src_sl]

        for done, part in enumerate(completed_map(fetch, tasks, nworkers), 1):
            if part is not None:
                out[part[0]] = part[1]
            if progress is not None:
                progress(done, len(tasks))
        if tup is not None:
            data = tp.lookup(palette, out[0], frame, tup["axis"])
        elif interleaved:
            data = il.unfold(out[0], nt, frame)
        else:
            data = out[0] if (len(shape) == 3 or frame is not None) else out
        if hdr.get("channels") == CHANNELS_LAST and frame is None:
            data = np.ascontiguousarray(np.moveaxis(data, 0, -1))
        return Volume(
            data, spacing=tuple(hdr["spacing"]), origin=origin, meta=dict(hdr.get("meta") or {})
        )


def open(source: Any, *, max_voxels: int = DEFAULT_MAX_VOXELS) -> VolumeReader:  # noqa: A001
    """Open a volume ``.vpk`` (a path, ``'-'``, bytes, a binary file or a container Reader)."""
    if isinstance(source, str) and source == "-":
        source = stdin()
    return VolumeReader(source, max_voxels=max_voxels)


def decompress(
    source: Any,
    *,
    roi: str | tuple[slice, ...] | None = None,
    frame: int | None = None,
    workers: int | None = 1,
    progress: Progress | None = None,
    max_voxels: int = DEFAULT_MAX_VOXELS,
) -> Volume:
    """Decode a volume ``.vpk``, or only the region ``roi`` of it (see :meth:`VolumeReader.read`)."""
    with open(source, max_voxels=max_voxels) as r:
        return r.read(roi=roi, frame=frame, workers=workers, progress=progress)


def info(source: str | BinaryIO) -> dict[str, Any]:
    """Describe a volume ``.vpk``: header, summary, sizes, ratio, chunks (JSON types)."""
    d = describe(source)
    check_header(d["header"])  # what info shows has been checked like what a decoder reads
    return d


def check_header(hdr: dict, max_voxels: int = DEFAULT_MAX_VOXELS) -> dict:
    """Validate a volume header (kind, keys, shape, dtype, brick, size limit); return it
    with ``shape`` and ``brick`` as tuples."""
    need = ("shape", "dtype", "spacing", "origin", "brick", "codec")
    if hdr.get("kind") != KIND or any(k not in hdr for k in need):
        raise FormatError(f"expected a volpack volume header with {need}, found keys {sorted(hdr)}")
    from ..format import header as h
    from .registry import get_codec

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
    if "layout" in hdr and (hdr["layout"] != il.LAYOUT or len(shape) != 4):
        raise FormatError(
            f"expected layout {il.LAYOUT!r} of a 4-D volume or none, found "
            f"{hdr['layout']!r:.40} of a {len(shape)}-D one"
        )
    if isinstance(hdr.get("channels"), dict):
        tp.check_header(hdr["channels"], shape, hdr["dtype"], "layout" in hdr)
    elif "channels" in hdr and (hdr["channels"] != CHANNELS_LAST or len(shape) != 4):
        raise FormatError(
            f"expected channels {CHANNELS_LAST!r} of a 4-D volume or none, found "
            f"{hdr['channels']!r:.40} of a {len(shape)}-D one"
        )
    hdr["shape"], hdr["brick"] = shape, brick_t
    return hdr


def parse_roi(roi, shape: tuple[int, ...]) -> tuple[slice, slice, slice]:
    """``None`` (everything), ``"z0:z1,y0:y1,x0:x1"`` or three slices, as three checked
    non-empty slices of step 1 inside ``shape``."""
    if roi is None:
        return tuple(slice(0, n) for n in shape)  # type: ignore[return-value]
    if isinstance(roi, str):
        from ..prep import parse_ranges

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


def _stdout():
    import sys

    return sys.stdout.buffer
