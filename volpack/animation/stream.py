"""Animated volumes: I/P/B frames with windowed 3-D motion compensation in a ``.vpk``.

Encoding walks the frames in storage order (:mod:`volpack.animation.gop`). An I-frame is coded
alone by one of volpack's brick codecs; a P-frame is predicted from the previous anchor,
a B-frame from the previous and next anchors (:mod:`volpack.animation.motion`), and the residual,
frame minus rounded prediction, is coded by the same codecs. Predictions are always made
from the *decoded* anchors, exactly as the decoder will, so errors do not build up along
a chain of P-frames; with ``max_error`` the encoder checks every voxel of every decoded
frame and stores any voxel past the bound exactly.

The encoder holds the current frame and at most two decoded anchors: frames are read
from their source one at a time, in storage order, so a sequence of any length streams
through in the memory of a few frames (a memory-mapped ``.npy`` or a list of files is
never loaded whole).

Each frame is one chunk ``(t, 0)`` of the container; the byte layout is
``formats/animation-1.md``. This module holds the stream (compress, the reader,
check_header, decompress, the summaries); one frame's codec is :mod:`volpack.animation.frame`,
the settings :mod:`volpack.animation.settings`, the frame sources
:mod:`volpack.animation.frames`.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterator
from typing import Any, BinaryIO

import numpy as np

from .. import __version__
from ..errors import FormatError, OptionError
from ..format.checked import CheckedReader
from ..jsonsafe import jsonable
from ..metrics import psnr_from_sse, throughput
from ..parallel import one_blas_thread
from ..volume import Volume
from ..volume_codec import bricks
from . import gop, motion, specials
from .frame import MODE_NAMES, CodedFrame, decode_frame, encode_frame
from .frames import is_pattern, open_frames
from .settings import Settings

KIND_ANIMATION = "animation"
ANIMATION_DTYPES = ("uint8", "int8", "uint16", "int16", "float32", "float64")


# -- whole animations -------------------------------------------------------------------


Progress = Callable[[int, int], None]


@one_blas_thread()
def compress(
    source: Any,
    target: str | BinaryIO,
    *,
    gop_string: str = "IBBPBBPBB",
    max_error: float | None = None,
    quality: int | None = None,
    wavelet: str | None = None,
    coder: str | None = None,
    order: str | None = None,
    max_levels: int | None = None,
    brick: int | tuple[int, int, int] | None = None,
    search: int = motion.DEFAULT_RADIUS,
    method: str = "fast",
    precision: str = "quarter",
    compensation: str = "windowed",
    b_residual: bool = True,
    whole_frame: bool = True,
    i_max_error: float | None = None,
    fill_value: float | None = None,
    codec: str = "auto",
    force: bool = False,
    progress: Progress | None = None,
    read_options: dict | None = None,
    **refused: Any,
) -> dict[str, Any]:
    """Compress a sequence of volumes (see :func:`open_frames`) as an animation.

    Lossless unless ``max_error`` (every voxel of every frame within it) or ``quality``
    (the coefficient codec's 255..15 scale, integer voxels) is given. Returns the
    summary also stored in the file: sizes, ratio, max error, PSNR, and per frame the
    type chosen, bytes, error and block modes (``global``: a whole-frame shift). With
    ``whole_frame`` a P/B-frame whose blocks move as one also tries the anchors moved
    whole through their spectra (:mod:`volpack.animation.shift`). I-frames that anchor predictions
    are coded to ``i_max_error`` when given (``max_error`` turns it off); by default to
    :func:`default_i_max_error` where the first GOP segment, coded both ways, says it
    pays (:func:`_tight_pays`). NaN, +-Inf and voxels equal to ``fill_value`` are
    kept out of prediction and coding and restored exactly
    (:mod:`volpack.animation.specials`); the error is that of the other voxels.
    """
    from ..format.container import Writer

    _refuse(codec, refused)
    if max_error is not None and quality is not None:
        raise OptionError("expected at most one of max_error and quality")
    mode = "bounded" if max_error is not None else "coef" if quality is not None else "lossless"
    if isinstance(source, str) and isinstance(target, (str, os.PathLike)):
        from ..format.atomic import check_output

        check_output(target, force=force, inputs=() if is_pattern(source) else (source,))
    src = open_frames(source, **(read_options or {}))
    types = gop.frame_types(gop_string, src.shape[0])
    trial_i = mode == "bounded" and i_max_error is None
    if trial_i:
        i_max_error = default_i_max_error(float(max_error), src.dtype, types)
    if i_max_error is not None and i_max_error == max_error:
        i_max_error = None
    inner = {"wavelet": wavelet, "coder": coder, "order": order, "max_levels": max_levels}
    s = Settings(
        mode, max_error, quality, search=int(search), method=method, precision=precision,
        compensation=compensation, b_residual=bool(b_residual), whole_frame=bool(whole_frame),
        i_max_error=i_max_error, fill_value=None if fill_value is None else float(fill_value),
        **{k: v for k, v in inner.items() if v is not None},
    )  # fmt: skip
    _check_dtype(src.dtype, s)
    if brick is None:  # as a 3-D volume: floats under a bound in whole frames
        brick = bricks.default_brick(src.shape[1:], src.dtype, mode == "bounded")
    brick_t = bricks.parse_brick(brick)
    nt = src.shape[0]
    refs = gop.references(types)
    release = gop.last_use(types)
    header = {
        "kind": KIND_ANIMATION,
        "volpack": __version__,
        "shape": list(src.shape),
        "dtype": np.dtype(src.dtype).newbyteorder("<").str,
        "spacing": list(src.spacing),
        "origin": list(src.origin),
        "brick": list(brick_t),
        "gop": gop.parse_gop(gop_string),
        "types": types,
        "codec": s.codec_config(),
        "motion": s.motion_config(),
        "meta": jsonable(src.meta),
    }
    frame_shape = tuple(src.shape[1:])
    order = gop.storage_order(types)
    rows: list[dict[str, Any]] = [{}] * nt
    lo, hi = math.inf, -math.inf
    sse_total, nbytes = 0.0, 0

    def read(t: int) -> np.ndarray:
        x = np.ascontiguousarray(src.get(t))
        if x.shape != frame_shape or x.dtype != src.dtype:
            raise FormatError(
                f"expected frame {t} to be {frame_shape} {src.dtype}, found {x.shape} {x.dtype}"
            )
        return x

    def coded(positions, anchors: dict, tight: bool, held=None):
        """Encode frames at these storage positions: ``(i, t, frame, CodedFrame)`` (the
        frames read from the source in storage order, or taken from ``held``)."""
        for i in positions:
            t = order[i]
            x = held[t] if held else read(t)
            p, n = refs[t]
            f = encode_frame(
                x, types[t], anchors.get(p) if p is not None else None,
                anchors.get(n) if n is not None else None, s, brick_t,
                tight and types[t] in gop.ANCHORS,
            )  # fmt: skip
            if types[t] in gop.ANCHORS:
                anchors[t] = specials.reference(f.decoded, s.fill_value)
            for a in [a for a in anchors if release[a] <= i]:
                del anchors[a]
            yield i, t, x, f

    t0 = time.perf_counter()
    with Writer(_stdout() if target == "-" else target, header, force=force) as w:

        def commit(i: int, t: int, x: np.ndarray, f: CodedFrame) -> None:
            nonlocal lo, hi, sse_total, nbytes
            w.write(t, 0, f.payload, f.max_error)
            flo, fhi = f.value_range
            lo, hi = min(lo, flo), max(hi, fhi)
            sse_total += f.sse
            nbytes += len(f.payload)
            rows[t] = {
                "t": t,
                "type": f.kind,
                "planned": types[t],
                "nbytes": len(f.payload),
                "motion_nbytes": f.motion_nbytes,
                "max_error": f.max_error,
                "sse": f.sse,
                "nvalid": f.nvalid,
                "modes": f.modes,
            }
            if progress is not None:
                progress(i + 1, nt)

        anchors: dict[int, motion.Reference] = {}
        tight, done = s.i_max_error is not None, 0
        if tight and trial_i:
            # the first GOP segment coded both ways decides the I-frames' bound
            n = _trial_length(types, order)
            held = {order[i]: read(order[i]) for i in range(n)}
            runs = {k: (list(coded(range(n), a, k, held)), a) for k, a in ((False, {}), (True, {}))}
            tight = _tight_pays(types, {k: [c[3] for c in r] for k, (r, _) in runs.items()})
            for c in runs[tight][0]:
                commit(*c)
            anchors, done = runs[tight][1], n
        for c in coded(range(done, len(order)), anchors, tight):
            commit(*c)
        summary = _summary(rows, src, nbytes, lo, hi, sse_total, s)
        w.close(summary=stored_summary(summary))
    seconds = time.perf_counter() - t0
    raw = summary["raw_nbytes"]
    return {
        **summary,
        "nbytes": nbytes,
        "seconds": seconds,
        "mb_per_s": throughput(raw, seconds),
    }


LOSSY_REFUSED = ("rel_error", "psnr", "ratio", "threshold")


def _refuse(codec: str | None, refused: dict) -> None:
    """Animations code frames with the wavelet codecs, lossless, to ``max_error`` or to
    ``quality``: the volume kind's other settings are refused by name."""
    unknown = sorted(set(refused) - set(LOSSY_REFUSED))
    if unknown:
        raise TypeError(f"compress() of an animation got unexpected options {unknown}")
    given = [k for k in LOSSY_REFUSED if refused.get(k) is not None]
    if given:
        raise OptionError(
            f"animations take max_error or quality (or neither: lossless); found {given[0]}"
        )
    if codec not in (None, "auto", "wavelet", "lossless"):
        raise OptionError(
            f"animations code frames with the wavelet and lossless codecs; found codec={codec!r}"
        )


def _trial_length(types: str, order: list[int]) -> int:
    """Storage positions of the first GOP segment: the first I-frame, the next anchor
    and the B-frames between them (those before the third anchor)."""
    seen = 0
    for i, t in enumerate(order):
        seen += types[t] in gop.ANCHORS
        if seen == 3:
            return i
    return len(order)


def _tight_pays(types: str, runs: dict[bool, list[CodedFrame]]) -> bool:
    """Whether the tighter I-frame bound pays, from the first GOP segment coded both ways
    (``runs[tight]``, storage order, the I-frame first): its extra bytes against the
    predicted frames' saving per frame, times the frames each I-frame anchors (all
    planned P and B up to the next planned I). The segment alone holds only the first
    P-frame and its B-frames; the saving recurs over the rest of the GOP."""
    extra = len(runs[True][0].payload) - len(runs[False][0].payload)
    saved = sum(len(f.payload) for f in runs[False][1:]) - sum(
        len(f.payload) for f in runs[True][1:]
    )
    anchored = len(types[1:].split("I")[0])
    return extra < saved * anchored / max(len(runs[True]) - 1, 1)


def default_i_max_error(max_error: float, dtype, types: str) -> float:
    """The candidate bound of I-frames that anchor predictions: two thirds of
    ``max_error`` (floored for integer voxels, never below 1), when some frame is
    predicted. P- and B-frames inherit their anchors' coding error where most of their
    residual quantises to zero, so cleaner I-frames can pay for themselves: on the 64^3
    head moving (0.5, 0.25, 0.75) voxels a frame (IBBPBBPBB) the ratio rose 2 % at E = 2
    (I at 1), 13 % at E = 4 (I at 2) and 16 % at E = 9 (I at 6), and coding the P anchors
    tighter too lost at every bound. But on the advected field it lost 8-20 % and on a
    growing blob 11 % at E = 2, so :func:`compress` codes the first GOP segment both
    ways and decides by :func:`_tight_pays`."""
    if not any(k in "PB" for k in types):
        return max_error
    if np.dtype(dtype).kind in "iu":
        i = math.floor(2 * max_error / 3)
        return float(i) if i >= 1 else max_error
    return 2 * max_error / 3


def _check_dtype(dtype: np.dtype, s: Settings) -> None:
    name = np.dtype(dtype).name
    if name not in ANIMATION_DTYPES:
        raise FormatError(
            f"expected animation voxels of {', '.join(ANIMATION_DTYPES)}, found {name}"
        )
    if np.dtype(dtype).kind == "f" and s.mode == "coef":
        raise OptionError(
            f"{name} animations are coded with max_error= or losslessly; found quality="
        )


def _psnr(sse: float, n: int, peak: float) -> float | None:
    if sse == 0 or n == 0:
        return None
    return psnr_from_sse(sse, n, max(peak, 1e-300))


def _summary(rows, src, nbytes, lo, hi, sse_total, s) -> dict[str, Any]:
    if lo > hi:  # no valid voxel in any frame
        lo = hi = 0.0
    peak = hi - lo
    nvalid = sum(r["nvalid"] for r in rows)
    for r in rows:
        r["psnr"] = _psnr(r.pop("sse"), r.pop("nvalid"), peak)
    raw = int(np.prod(src.shape)) * np.dtype(src.dtype).itemsize
    counts = {k: sum(r["type"] == k for r in rows) for k in "IPB"}
    modes: dict[str, int] = {}
    for r in rows:
        for k, v in r["modes"].items():
            modes[k] = modes.get(k, 0) + v
    lossless = s.mode == "lossless"
    return {
        "raw_nbytes": raw,
        "payload_nbytes": nbytes,
        "ratio": raw / max(nbytes, 1),
        "lossless": lossless,
        "mode": s.mode,
        "max_error": max((r["max_error"] for r in rows), default=0.0),
        "error_bound": s.max_error,
        "psnr": _psnr(sse_total, nvalid, peak),
        "rmse": math.sqrt(sse_total / max(nvalid, 1)),
        "value_range": [lo, hi],
        "frame_types": counts,
        "scene_cuts": sum(r["type"] == "I" and r["planned"] != "I" for r in rows),
        "block_modes": modes,
        "motion_nbytes": sum(r["motion_nbytes"] for r in rows),
        "frames": rows,
    }


# The per-frame rows are stored by column: on a short series of small frames the JSON
# of one dict per frame (its keys repeated every time) outweighed the frames' data.
def stored_summary(summary: dict[str, Any]) -> dict[str, Any]:
    """``summary`` as the file stores it: ``frames`` turned into ``frame_columns``."""
    rows = summary["frames"]
    out = {k: v for k, v in summary.items() if k != "frames"}
    out["frame_columns"] = {
        "type": "".join(r["type"] for r in rows),
        "nbytes": [r["nbytes"] for r in rows],
        "motion_nbytes": [r["motion_nbytes"] for r in rows],
        "max_error": [r["max_error"] for r in rows],
        "psnr": [None if r["psnr"] is None else round(r["psnr"], 4) for r in rows],
        "modes": [[r["modes"].get(m, 0) for m in MODE_NAMES] if r["modes"] else [] for r in rows],
    }
    return out


def frame_rows(summary: dict, planned: str) -> list[dict[str, Any]]:
    """The per-frame rows of a stored summary (``t``, ``type``, ``planned``, ``nbytes``,
    ``motion_nbytes``, ``max_error``, ``psnr``, ``modes``); files that stored rows
    return them as they are."""
    if "frames" in summary:
        return list(summary["frames"])
    c = summary.get("frame_columns") or {}
    try:
        n = len(c["type"])
        return [
            {
                "t": t,
                "type": c["type"][t],
                "planned": planned[t] if t < len(planned) else c["type"][t],
                "nbytes": c["nbytes"][t],
                "motion_nbytes": c["motion_nbytes"][t],
                "max_error": c["max_error"][t],
                "psnr": c["psnr"][t],
                "modes": dict(zip(MODE_NAMES, c["modes"][t])),
            }
            for t in range(n)
        ]
    except (KeyError, IndexError, TypeError) as e:
        raise FormatError(f"animation summary: bad frame columns ({e!r})") from None


class AnimationReader(CheckedReader):
    """Decode frames of an animation ``.vpk``: one frame with only the anchors it needs
    (:meth:`frame`), all frames (:meth:`frames`), or the playback schedule (:meth:`play`)."""

    def __init__(self, source: Any, *, max_voxels: int = 1 << 34) -> None:
        super().__init__(source, check_header, max_voxels)
        h = self.header
        self.shape = tuple(h["shape"])
        self.dtype = np.dtype(h["dtype"]).newbyteorder("=")
        self.types = h["types"]
        self.brick = tuple(h["brick"])
        self.settings = Settings.from_header(h)
        self.refs = gop.references(self.types)
        self.decoded = 0  # frames decoded so far (what --frame promises to keep small)

    @property
    def summary(self) -> dict | None:
        """The stored summary, per-frame rows expanded (:func:`frame_rows`)."""
        summ = self._r.summary
        if summ is None:
            return None
        return {**summ, "frames": frame_rows(summ, self.types)}

    def _decode(self, t: int, payload: bytes, prev, nxt) -> motion.Reference:
        self.decoded += 1
        frame = decode_frame(
            payload, self.shape[1:], self.dtype, prev, nxt, self.settings, self.brick
        )[1]
        return specials.reference(frame, self.settings.fill_value)

    def _read(self, t: int) -> bytes:
        return self._r.read(t, 0)

    def frame(self, t: int) -> np.ndarray:
        """Frame ``t``, decoding only its chain of anchors."""
        nt = self.shape[0]
        if not 0 <= t < nt:
            raise FormatError(f"expected a frame in 0..{nt - 1}, found {t}")
        done: dict[int, np.ndarray] = {}
        for f in gop.needed(self.types, t):
            p, n = self.refs[f]
            done[f] = self._decode(f, self._read(f), done.get(p), done.get(n))
        return done[t].exact

    def play(self) -> Iterator[tuple[int, np.ndarray]]:
        """Frames in display order, one decode per step (seekable files)."""
        for t, ref in gop.play(self.types, lambda t, p, n: self._decode(t, self._read(t), p, n)):
            yield t, ref.exact

    def frames(self, progress: Progress | None = None) -> np.ndarray:
        """All frames ``(t, z, y, x)``, decoded in storage order (streams work too)."""
        out = np.empty(self.shape, self.dtype)
        anchors: dict[int, np.ndarray] = {}
        release = gop.last_use(self.types)
        order = gop.storage_order(self.types)
        pos = {t: i for i, t in enumerate(order)}
        count = 0
        for i, (t, node, payload) in enumerate(self._r):
            count += 1
            if node != 0 or not 0 <= t < len(self.types) or pos.get(t) != i:
                raise FormatError(
                    f"expected frame {order[i] if i < len(order) else '-'} next, found chunk ({t}, {node})"
                )
            p, n = self.refs[t]
            if (p is not None and p not in anchors) or (n is not None and n not in anchors):
                raise FormatError(f"frame {t} comes before its anchors")
            ref = self._decode(t, payload, anchors.get(p), anchors.get(n))
            out[t] = ref.exact
            if self.types[t] in gop.ANCHORS:
                anchors[t] = ref
            for a in [a for a in anchors if release[a] <= i]:
                del anchors[a]
            if progress is not None:
                progress(i + 1, len(order))
        if count != len(order):
            raise FormatError(f"expected {len(order)} frames, found {count}")
        return out


def check_header(hdr: dict, max_voxels: int = 1 << 34) -> dict:
    """Validate an animation header (kind, keys, shape, dtype, frame types); return it."""
    need = ("shape", "dtype", "brick", "types", "codec", "motion", "spacing", "origin")
    if hdr.get("kind") != KIND_ANIMATION:
        raise FormatError(
            f"expected an animation .vpk (kind {KIND_ANIMATION!r}), found kind "
            f"{hdr.get('kind')!r}; build one with gop='IPPP'"
        )
    if any(k not in hdr for k in need):
        raise FormatError(f"expected an animation header with {need}, found keys {sorted(hdr)}")
    from ..format import header as h

    shape = h.shape(hdr["shape"], "shape", (4,), max_voxels)
    dtype = h.dtype(hdr["dtype"])
    try:
        brick_t = bricks.parse_brick(hdr["brick"])
    except (TypeError, ValueError, OverflowError) as e:
        raise FormatError(f"bad animation header: {e}") from None
    if dtype.newbyteorder("=").name not in ANIMATION_DTYPES:
        raise FormatError(f"expected animation voxels of {ANIMATION_DTYPES}, found {dtype}")
    types = gop.check_types(hdr["types"])
    if len(types) != shape[0]:
        raise FormatError(f"expected {shape[0]} frame types, found {len(types)}")
    hdr = dict(hdr)
    hdr["spacing"] = h.vector(hdr["spacing"], "spacing", 3, positive=True)
    hdr["origin"] = h.vector(hdr["origin"], "origin", 3)
    if not isinstance(hdr.get("meta", {}), dict):
        raise FormatError(f"expected meta as a JSON object, found {hdr['meta']!r:.60}")
    hdr["shape"], hdr["brick"] = shape, brick_t
    return hdr


def open(source: Any, *, max_voxels: int = 1 << 34) -> AnimationReader:  # noqa: A001
    """Open an animation ``.vpk`` (a path, ``'-'``, bytes, a file or a container Reader)."""
    if isinstance(source, str) and source == "-":
        from ..format.streams import stdin

        source = stdin()
    return AnimationReader(source, max_voxels=max_voxels)


def decompress(
    source: Any,
    *,
    frame: int | None = None,
    roi: str | tuple[slice, ...] | None = None,
    progress: Progress | None = None,
    max_voxels: int = 1 << 34,
    workers: int | None = None,
) -> Volume:
    """Decode an animation ``.vpk`` (a path, bytes, a file or an open container
    Reader): all frames ``(t, z, y, x)``, or one frame decoding only the anchors it
    needs; ``roi`` crops the decoded frames. Frames decode one after another
    (``workers`` is accepted for the common signature of the stream kinds)."""
    from ..volume_codec.stream import parse_roi

    with open(source, max_voxels=max_voxels) as r:
        data = r.frame(frame) if frame is not None else r.frames(progress)
        h = r.header
    region = parse_roi(roi, data.shape[-3:])
    data = np.ascontiguousarray(data[(..., *region)]) if roi is not None else data
    origin = tuple(o + s.start * d for o, s, d in zip(h["origin"], region, h["spacing"]))
    return Volume(data, spacing=tuple(h["spacing"]), origin=origin, meta=dict(h.get("meta") or {}))


def info(source: str | BinaryIO) -> dict[str, Any]:
    """Describe an animation ``.vpk`` as the container sees it (header with the frame
    types, the summary with its per-frame columns, chunk sizes)."""
    from ..format.describe import describe

    d = describe(source)
    check_header(d["header"])  # what info shows has been checked like what a decoder reads
    return d


def _stdout():
    import sys

    return sys.stdout.buffer
