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
``formats/animation-1.md``.
"""

from __future__ import annotations

import dataclasses
import glob
import logging
import math
import os
import re
import struct
import time
from collections.abc import Callable, Iterator
from typing import Any, BinaryIO

import numpy as np

from .. import __version__
from .._jit import kernel
from ..errors import FormatError, OptionError
from ..format.container import put_section, take_section
from ..volume import Volume
from ..volume_codec import bricks
from . import gop, motion, shift

log = logging.getLogger(__name__)

KIND_ANIMATION = "animation"
TYPE_CODE = {"I": 0, "P": 1, "B": 2}
FLAG_RESIDUAL, FLAG_CORRECTIONS, FLAG_FLAT, FLAG_GLOBAL, FLAG_I_BOUND = 1, 2, 4, 0x40, 0x80
SMOOTH_SHIFT, SMOOTH_MASK = 3, 0x38  # flag bits 3-5: index into motion.SMOOTHING
INTRA_CUT = 0.5  # a frame with at least this share of intra blocks is coded as an I-frame
# A whole-frame shift is tried when at least this share of the blocks reading an anchor
# hold a vector within a quarter voxel of their median: the scene moves as one.
COHERENT = 0.5
_FRAME_HEAD = struct.Struct("<BBdddd")  # type, flags, lo, hi, value range, mean unit
ANIMATION_DTYPES = ("uint8", "int8", "uint16", "int16", "float32", "float64")


# -- settings ----------------------------------------------------------------------------


@dataclasses.dataclass(frozen=True)
class Settings:
    """How frames are coded; stored in the header (``codec`` and ``motion``)."""

    mode: str = "lossless"  # lossless | bounded | coef
    max_error: float | None = None
    quality: int | None = None
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None
    search: int = motion.DEFAULT_RADIUS
    method: str = "fast"
    precision: str = "quarter"
    compensation: str = "windowed"
    b_residual: bool = True
    rule: str = motion.RULE
    whole_frame: bool = True  # whole-frame shifts tried where the scene moves as one
    i_max_error: float | None = None  # bound of I-frames that anchor others (None: max_error)

    def __post_init__(self) -> None:
        if self.mode not in ("lossless", "bounded", "coef"):
            raise OptionError(f"expected mode lossless, bounded or coef, found {self.mode!r}")
        if self.mode == "bounded" and not (
            self.max_error is not None and self.max_error > 0 and math.isfinite(self.max_error)
        ):
            raise OptionError(f"expected a positive finite max_error, found {self.max_error!r}")
        if self.i_max_error is not None and not (
            self.mode == "bounded" and 0 < self.i_max_error <= self.max_error
        ):
            raise OptionError(
                f"expected i_max_error, an I-frame bound, in (0, max_error = "
                f"{self.max_error}] with max_error=, found {self.i_max_error!r} in "
                f"{self.mode} coding"
            )
        if self.mode == "coef" and not (self.quality and 1 <= int(self.quality) <= 65535):
            raise OptionError(f"expected a quality in 1..65535, found {self.quality!r}")
        if self.method not in motion.SEARCH_METHODS:
            raise OptionError(
                f"expected a motion search method in {motion.SEARCH_METHODS}, found {self.method!r}"
            )
        if self.precision not in motion.PRECISIONS:
            raise OptionError(
                f"expected a vector precision in {motion.PRECISIONS}, found {self.precision!r}"
            )
        if self.compensation not in motion.COMPENSATIONS:
            raise OptionError(
                f"expected compensation in {motion.COMPENSATIONS}, found {self.compensation!r}"
            )
        if self.rule != motion.RULE:
            raise OptionError(f"expected the prediction rule {motion.RULE!r}, found {self.rule!r}")
        if not 0 <= int(self.search) <= 64:
            raise OptionError(f"expected a search range of 0..64 voxels, found {self.search}")
        if not self.b_residual and self.mode != "coef":
            raise OptionError(
                "B-frames without a residual have no error bound: use them with quality= only"
            )

    def codec_config(self) -> dict[str, Any]:
        keys = ("mode", "max_error", "quality", "wavelet", "coder", "order", "max_levels")
        out = {k: getattr(self, k) for k in keys}
        if self.i_max_error is not None:
            out["i_max_error"] = self.i_max_error
        return out

    def anchor_i(self) -> Settings:
        """The settings of an I-frame that anchors predictions (flag bit 7)."""
        return dataclasses.replace(self, max_error=self.i_max_error, i_max_error=None)

    def motion_config(self) -> dict[str, Any]:
        keys = ("search", "method", "precision", "compensation", "b_residual", "rule")
        keys += ("whole_frame",)
        return {k: getattr(self, k) for k in keys}

    @classmethod
    def from_header(cls, hdr: dict) -> Settings:
        if isinstance(hdr.get("motion"), dict) and "rule" not in hdr["motion"]:
            raise FormatError(
                "animation coded with an earlier prediction rule (no motion.rule in its "
                f"header; quarter-voxel samples were box means): this volpack predicts by "
                f"rule {motion.RULE!r} only, so encode the frames again"
            )
        from ..format.header import dataclass_config

        codec = dataclass_config(cls, hdr["codec"], "animation codec settings")
        moves = dataclass_config(cls, hdr["motion"], "animation motion settings")
        try:
            return cls(**codec, **moves)
        except (KeyError, TypeError, ValueError, ArithmeticError) as e:
            raise FormatError(f"bad animation header settings: {e}") from None

    def inner(self) -> dict[str, Any]:
        d = {"wavelet": self.wavelet, "coder": self.coder, "order": self.order}
        if self.max_levels is not None:
            d["max_levels"] = self.max_levels
        return d

    def scale(self, vrange: float) -> float:
        """The size of an error this setting treats as small (motion search penalty)."""
        if self.mode == "bounded":
            return float(self.max_error)
        if self.mode == "coef":
            return max(vrange, 1.0) / (int(self.quality) + 1)
        return 1.0


def _field_codec(s: Settings, dtype: np.dtype, lo: float, hi: float, vrange: float):
    """The brick codec for one coded field (a frame or a residual) of ``dtype``."""
    if s.mode == "lossless":
        from ..volume_codec.codec import WaveletCodec

        return WaveletCodec(**s.inner())
    if s.mode == "coef":
        from ..volume_codec.lossy import CoefCodec

        return CoefCodec(value_range=max(vrange, 1.0), quality=int(s.quality), **s.inner())
    from ..volume_codec.lossy import BoundedCodec

    return BoundedCodec.plan(dtype, lo, hi, s.max_error, **s.inner())


def _code_bricks(s: Settings, target: np.ndarray, lo: float, hi: float, vrange: float, brick):
    """Every brick of ``target`` coded by the field codec (length-prefixed sections),
    and the field decoded back."""
    from ..api import encode_measured

    c = _field_codec(s, target.dtype, lo, hi, vrange)
    rec = np.empty(target.shape, target.dtype)
    bodies = []
    for _, sl in bricks.iter_bricks(target.shape, brick):
        b = np.ascontiguousarray(target[sl])
        payload = encode_measured(c, b)[0]
        bodies.append(put_section(payload))
        rec[sl] = c.decode(payload, b.shape, target.dtype)
    return bodies, rec


# -- flat fields: the residual quantised voxel by voxel ----------------------------------
#
# The residual of a good prediction at a tight bound is mostly rounding noise, which a
# wavelet cannot compact. Quantised voxel by voxel with bins of 2E + 1 (integers; 2E for
# floats) centred on zero and coded by the arithmetic coder in line order, whose contexts
# are the neighbours already coded, it costs close to the entropy of the quantised noise
# (on the advected field's P-frames 0.7-0.8x the wavelet path's bytes). The encoder
# makes both and keeps the shorter (lossless and bounded modes).

FLAT_LIMIT = 1 << 31  # largest quantiser index a flat field may hold


def _flat_step(s: Settings, dtype: np.dtype) -> float:
    if s.mode == "lossless":
        return 1.0
    if dtype.kind in "iu":
        return float(2 * math.floor(s.max_error) + 1)
    return 2.0 * float(s.max_error)


def _arith_line(values: np.ndarray) -> bytes:
    from ..entropy import arith
    from ..wavelet import sigmap

    return arith.encode(values, sigmap.scan(values.shape, (0, 0, 0), "line"))


def _arith_line_decode(data, shape: tuple[int, ...]) -> np.ndarray:
    from ..entropy import arith
    from ..wavelet import sigmap

    out = np.empty(shape, np.int64)
    arith.decode(data, sigmap.scan(shape, (0, 0, 0), "line"), out)
    return out


def encode_flat(target: np.ndarray, step: float) -> tuple[bytes, np.ndarray] | None:
    """``target`` quantised with bins of ``step`` centred on zero and arithmetic coded;
    returns ``(body, decoded)``, or None if the indices would not fit."""
    if target.dtype.kind in "iu":
        e = (int(step) - 1) // 2
        q = (target.astype(np.int64) + e) // int(step)
    else:
        q = np.rint(target / step)
        if not np.abs(q).max(initial=0) < FLAT_LIMIT:
            return None
        q = q.astype(np.int64)
    if np.abs(q).max(initial=0) >= FLAT_LIMIT:
        return None
    return _arith_line(np.ascontiguousarray(q)), _flat_values(q, step, target.dtype)


def decode_flat(body, shape: tuple[int, ...], step: float, dtype: np.dtype) -> np.ndarray:
    q = _arith_line_decode(body, shape)
    if np.abs(q).max(initial=0) >= FLAT_LIMIT:
        raise FormatError("animation frame: a flat field index out of range")
    return _flat_values(q, step, dtype)


def _flat_values(q: np.ndarray, step: float, dtype: np.dtype) -> np.ndarray:
    if dtype.kind in "iu":  # a bin's centre may lie past the dtype's end: clip
        info = np.iinfo(dtype)
        return np.clip(q * int(step), info.min, info.max).astype(dtype)
    return (q * step).astype(dtype)


def _residual_dtype(dtype: np.dtype) -> np.dtype:
    if dtype.kind == "f":
        return np.dtype(np.float64)
    return np.dtype(np.int16 if dtype.itemsize == 1 else np.int32)


# -- frame sources -----------------------------------------------------------------------


@dataclasses.dataclass
class FrameSource:
    """A sequence of 3-D frames read one at a time."""

    shape: tuple[int, int, int, int]
    dtype: np.dtype
    get: Callable[[int], np.ndarray]
    spacing: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    meta: dict = dataclasses.field(default_factory=dict)


def _natural_key(path: str) -> list:
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", path)]


def frame_paths(pattern: str) -> list[str]:
    """Files matching a glob pattern, in natural name order (``f2`` before ``f10``)."""
    paths = sorted(glob.glob(pattern), key=_natural_key)
    if not paths:
        raise FormatError(f"expected files matching {pattern!r}, found none")
    return paths


def is_pattern(source: Any) -> bool:
    return isinstance(source, str) and any(c in source for c in "*?[")


def open_frames(source: Any, **read_options: Any) -> FrameSource:
    """A :class:`FrameSource` over a ``(t, z, y, x)`` array or Volume (memory-mapped
    arrays stay on disk), a 4-D file, a glob pattern or a list of 3-D files."""
    from .. import io as vio

    if isinstance(source, FrameSource):
        return source
    if isinstance(source, (str, os.PathLike)) and not is_pattern(str(source)):
        source = vio.read_volume(str(source), **read_options)
    if isinstance(source, Volume) or isinstance(source, np.ndarray):
        vol = source if isinstance(source, Volume) else Volume(source)
        data = vol.data if vol.data.ndim == 4 else vol.data[None]
        return FrameSource(
            tuple(data.shape), data.dtype, lambda t: np.asarray(data[t]), vol.spacing,
            vol.origin, dict(vol.meta),
        )  # fmt: skip
    paths = frame_paths(source) if is_pattern(source) else [str(p) for p in source]
    if not paths:
        raise FormatError("expected at least one frame file, found an empty list")
    heads = [vio.read_header(p, **read_options) for p in paths]
    first = heads[0]
    for p, h in zip(paths, heads):
        if tuple(h["shape"]) != tuple(first["shape"]) or np.dtype(h["dtype"]) != np.dtype(
            first["dtype"]
        ):
            raise FormatError(
                f"expected every frame to be {tuple(first['shape'])} {np.dtype(first['dtype'])} "
                f"like {paths[0]!r}, found {tuple(h['shape'])} {np.dtype(h['dtype'])} in {p!r}"
            )
    if len(first["shape"]) != 3:
        raise FormatError(f"expected 3-D frame files, found shape {first['shape']} in {paths[0]!r}")

    def get(t: int) -> np.ndarray:
        return vio.read_volume(paths[t], **read_options).data

    return FrameSource(
        (len(paths), *first["shape"]), np.dtype(first["dtype"]), get,
        tuple(first["spacing"]), tuple(first["origin"]), {"frames": len(paths)},
    )  # fmt: skip


# -- motion field bytes ------------------------------------------------------------------


def encode_field(field: motion.MotionField, two_way: bool, mean_unit: float) -> bytes:
    """The motion field as stacked integer planes (mode, vectors, intra constants),
    coded by the adaptive arithmetic coder in line order."""
    return _arith_line(_planes(field, two_way, mean_unit))


def decode_field(
    data: bytes, grid: tuple[int, int, int], two_way: bool, mean_unit: float, radius: int
):
    nf = 8 if two_way else 5
    p = _arith_line_decode(data, (nf * grid[0], grid[1], grid[2])).reshape(nf, *grid)
    mode = p[0]
    allowed = (0, 1, 2, 3) if two_way else (0, 3)
    if not np.isin(mode, allowed).all():
        raise FormatError(
            f"motion field: expected block modes in {allowed}, found {np.unique(mode)}"
        )
    vec = p[1 : nf - 1]
    if np.abs(vec).max(initial=0) > 4 * radius + 3:
        raise FormatError(f"motion field: a vector exceeds the search range of {radius} voxels")
    fwd = np.ascontiguousarray(np.moveaxis(vec[:3], 0, -1))
    bwd = np.ascontiguousarray(np.moveaxis(vec[3:6], 0, -1)) if two_way else np.zeros_like(fwd)
    return motion.MotionField(mode.astype(np.uint8), fwd, bwd, p[nf - 1] * mean_unit)


def _planes(field: motion.MotionField, two_way: bool, mean_unit: float) -> np.ndarray:
    parts = [field.mode.astype(np.int64)[None], np.moveaxis(field.fwd, -1, 0)]
    if two_way:
        parts.append(np.moveaxis(field.bwd, -1, 0))
    parts.append(np.rint(field.mean / mean_unit).astype(np.int64)[None])
    p = np.concatenate(parts)
    return np.ascontiguousarray(p.reshape(-1, *p.shape[2:]))


# -- whole-frame shifts ------------------------------------------------------------------


def _global_allowed(s: Settings, dtype: np.dtype) -> bool:
    """Whole-frame shifts (when the settings allow them) for integer frames in the
    voxel-domain modes: there the encoder can store exactly the few voxels a decoder's
    transform might round otherwise."""
    return s.whole_frame and dtype.kind in "iu" and dtype.itemsize <= 2 and s.mode != "coef"


def _coherent_starts(field: motion.MotionField, two_way: bool) -> list | None:
    """Per anchor the median vector (voxels) of the blocks reading it, when the field
    moves as one (:data:`COHERENT`); else None."""
    uses = [(field.fwd, (motion.MODE_FWD, motion.MODE_BI))]
    if two_way:
        uses.append((field.bwd, (motion.MODE_BWD, motion.MODE_BI)))
    starts = []
    for vec, modes in uses:
        v = vec[np.isin(field.mode, modes)]
        if not len(v):
            return None
        med = np.median(v, axis=0)
        if np.mean(np.all(np.abs(v - med) <= 1, axis=1)) < COHERENT:
            return None
        starts.append(med / 4.0)
    return starts


def _global_prediction(refs: list, vecs, w: float = 1.0) -> np.ndarray:
    """The anchor moved by its vector, or two anchors moved and mixed ``w : 1 - w``."""
    ws = [w, 1.0 - w] if len(refs) == 2 else [1.0]
    return shift.shifted(
        [(r.spectrum, v, c) for r, v, c in zip(refs, vecs, ws)], refs[0].frame.shape
    )


# The weights of the previous anchor a B-frame's whole-frame shift may take: an anchor
# coded to a tighter bound, or nearer, predicts better (on the 64^3 moving head at max
# error 2, 3/4 of the I-frame two frames back against 1/4 of the P-frame one frame
# ahead cut that B-frame by 14 %).
B_WEIGHTS = tuple(k / 8 for k in range(1, 8))


def _choose_weight(x: np.ndarray, refs: list, vecs, s: Settings) -> float:
    """The weight in :data:`B_WEIGHTS` whose mixed prediction leaves the quantised
    residual of least entropy (8/16-bit frames, as whole-frame shifts are)."""
    a, b = (shift.shifted([(r.spectrum, v, 1.0)], x.shape) for r, v in zip(refs, vecs))
    step = _flat_step(s, x.dtype)
    bits = [_counts_bits(_residual_counts(x, w * a + (1 - w) * b, step), x.size) for w in B_WEIGHTS]
    return B_WEIGHTS[int(np.argmin(bits))]


def decode_global(data, two_way: bool, radius: int) -> tuple[list[np.ndarray], float]:
    """The vectors of a whole-frame shift, and the previous anchor's weight."""
    n = 7 if two_way else 3
    if len(data) != 8 * n:
        raise FormatError(f"whole-frame shift: expected {8 * n} bytes, found {len(data)}")
    v = np.frombuffer(bytes(data), "<f8").astype(np.float64)
    w, v = (v[0], v[1:]) if two_way else (1.0, v)
    if not np.isfinite(v).all() or np.abs(v).max() > radius + 0.75:
        raise FormatError(
            f"whole-frame shift: expected vectors within {radius + 0.75} voxels, found {v.tolist()}"
        )
    if not 0.0 <= w <= 1.0:
        raise FormatError(f"whole-frame shift: expected a weight in [0, 1], found {w}")
    return ([v[:3], v[3:]] if two_way else [v]), float(w)


# -- one frame ---------------------------------------------------------------------------


@dataclasses.dataclass
class CodedFrame:
    payload: bytes
    decoded: np.ndarray
    kind: str  # the type it was coded as
    max_error: float
    sse: float
    motion_nbytes: int
    modes: dict[str, int]


def _frame_range(x: np.ndarray) -> tuple[float, float]:
    return (float(x.min()), float(x.max())) if x.size else (0.0, 0.0)


def _planned_range(s: Settings, dtype: np.dtype, lo: float, hi: float) -> tuple[float, float]:
    """Lower end of the coded range moved onto the quantiser's grid, so that a zero
    residual decodes to exactly zero."""
    if s.mode != "bounded" or lo >= 0:
        return lo, hi
    step = 2 * math.floor(s.max_error) + 1 if dtype.kind in "iu" else 2.0 * s.max_error
    return -math.ceil(-lo / step) * step, hi


def encode_frame(
    x: np.ndarray,
    kind: str,
    prev: motion.Reference | None,
    nxt: motion.Reference | None,
    s: Settings,
    brick: tuple[int, int, int],
    anchor: bool = False,
) -> CodedFrame:
    """Code one frame as ``kind``, or as an I-frame where prediction does not pay: when
    half the blocks or more are intra (a scene cut), or when the predicted frame comes
    out longer than the frame coded alone (both are made and the shorter kept). An
    I-frame that is an ``anchor`` is coded to ``s.i_max_error`` when set."""
    dtype = x.dtype
    lo0, hi0 = _frame_range(x)
    vrange = hi0 - lo0
    mean_unit = 1.0 if dtype.kind in "iu" else max(vrange / 4096.0, 1e-300)
    field, global_vecs = None, None
    if kind != "I":
        pen = 0.01 * motion.BLOCK**3 * s.scale(vrange) ** 2
        best = None
        for precision in _precisions(s):
            f = motion.choose_modes(
                x, prev, nxt if kind == "B" else None, radius=s.search, method=s.method,
                precision=precision, penalty=pen, mean_unit=mean_unit,
            )  # fmt: skip
            if best is None and np.mean(f.mode == motion.MODE_INTRA) >= INTRA_CUT:
                break  # a scene cut: nothing to predict from
            motion_bytes = encode_field(f, kind == "B", mean_unit)
            pred = motion.compensate(
                f, prev, nxt if kind == "B" else None, compensation=s.compensation
            )
            strength, bits = _choose_smoothing(x, pred, s)
            cost = bits + 8 * len(motion_bytes)
            if best is None or cost < best[0]:
                best = (cost, f, motion_bytes, pred, strength, None)
        if best is not None and _global_allowed(s, dtype):
            starts = _coherent_starts(best[1], kind == "B")
            if starts is not None:
                refs = [prev, nxt] if kind == "B" else [prev]
                reach = s.search + 0.75
                vecs = [shift.estimate(x, r.spectrum, v, reach) for r, v in zip(refs, starts)]
                w = _choose_weight(x, refs, vecs, s) if kind == "B" else 1.0
                # made again through the spectra, as the decoder makes it (not mixed
                # from the weight search's two frames), so the rounding guard sees the
                # decoder's own arithmetic
                pred = _global_prediction(refs, vecs, w)
                head = [w] if kind == "B" else []
                motion_bytes = np.asarray(head + [d for v in vecs for d in v], "<f8").tobytes()
                strength, bits = _choose_smoothing(x, pred, s)
                cost = bits + 8 * len(motion_bytes)
                if cost < best[0]:
                    best = (cost, best[1], motion_bytes, pred, strength, (vecs, w))
        if best is None:
            kind = "I"
        else:
            _, field, motion_bytes, pred, strength, global_vecs = best
    head_parts: list[bytes] = []
    flags = 0
    if kind == "I" and anchor and s.i_max_error is not None:
        s = s.anchor_i()
        flags |= FLAG_I_BOUND
    guard = None
    if field is None:
        pred_int = None
        target = x
        fdtype = dtype
    else:
        head_parts.append(put_section(motion_bytes))
        flags |= motion.SMOOTHING.index(strength) << SMOOTH_SHIFT
        smoothed = motion.smooth(pred, strength)
        if global_vecs is not None:
            flags |= FLAG_GLOBAL
            guard = shift.ambiguous(smoothed, float(np.abs(smoothed).max(initial=0.0)))
        pred_int = _rounded(smoothed, dtype)
        if dtype.kind in "iu":
            target = (x.astype(np.int64) - pred_int).astype(_residual_dtype(dtype))
        else:
            target = x.astype(np.float64) - pred_int
        fdtype = target.dtype
    residual = kind != "B" or s.b_residual
    lo, hi = _planned_range(s, fdtype, *_frame_range(target))
    bodies = []
    if residual:
        flags |= FLAG_RESIDUAL
        bodies, rec = _code_bricks(s, target, lo, hi, vrange, brick)
        flat = encode_flat(target, _flat_step(s, fdtype)) if s.mode != "coef" else None
        if flat is not None and len(flat[0]) + 4 < sum(map(len, bodies)):
            flags |= FLAG_FLAT
            bodies, rec = [put_section(flat[0])], flat[1]
        out = _combine(pred_int, rec, dtype)
    else:
        out = _combine(pred_int, None, dtype)
    err = np.abs(out.astype(np.float64) - x.astype(np.float64))
    corr = b""
    # rounding to the output dtype pushed these past the bound
    bad = np.flatnonzero(err > s.max_error) if s.mode == "bounded" else np.empty(0, np.int64)
    if guard is not None:  # and a decoder's transform could round these differently
        bad = np.union1d(bad, guard)
    if bad.size:
        flags |= FLAG_CORRECTIONS
        out.reshape(-1)[bad] = x.reshape(-1)[bad]
        err.reshape(-1)[bad] = 0.0
        from ..volume_codec.lossy import pack_corrections

        corr = put_section(pack_corrections(x, bad))
    head = _FRAME_HEAD.pack(TYPE_CODE[kind], flags, lo, hi, vrange, mean_unit)
    payload = b"".join([head, *head_parts, *bodies, corr])
    modes = {} if field is None else dict.fromkeys(MODE_NAMES, 0)
    if global_vecs is not None:
        modes["global"] = int(field.mode.size)
    elif field is not None:
        modes.update(field.counts())
    mnb = len(head_parts[0]) if head_parts else 0
    coded = CodedFrame(
        payload, out, kind, float(err.max(initial=0.0)), float(np.sum(err * err)), mnb, modes
    )
    if kind != "I":  # a prediction that costs more than the frame alone is dropped
        alone = encode_frame(x, "I", None, None, s, brick, anchor)
        if len(alone.payload) < len(payload):
            return alone
    return coded


def decode_frame(
    payload: bytes,
    shape: tuple[int, int, int],
    dtype: np.dtype,
    prev: motion.Reference | None,
    nxt: motion.Reference | None,
    s: Settings,
    brick: tuple[int, int, int],
) -> tuple[str, np.ndarray]:
    """Decode one frame chunk; returns ``(type coded, frame)``."""
    data = memoryview(payload)
    if len(data) < _FRAME_HEAD.size:
        raise FormatError(
            f"animation frame: expected at least {_FRAME_HEAD.size} bytes, found {len(data)}"
        )
    code, flags, lo, hi, vrange, mean_unit = _FRAME_HEAD.unpack(data[: _FRAME_HEAD.size])
    kinds = {v: k for k, v in TYPE_CODE.items()}
    if (
        code not in kinds
        or (flags & FLAG_FLAT and not flags & FLAG_RESIDUAL)
        or (code == TYPE_CODE["I"] and flags & (SMOOTH_MASK | FLAG_GLOBAL))
        or (code != TYPE_CODE["I"] and flags & FLAG_I_BOUND)
    ):
        raise FormatError(f"animation frame: unknown type {code} or flags {flags:#x}")
    kind = kinds[code]
    if flags & FLAG_I_BOUND:
        if s.i_max_error is None:
            raise FormatError("animation frame: coded to an I-frame bound the header lacks")
        s = s.anchor_i()
    if not all(math.isfinite(v) for v in (lo, hi, vrange, mean_unit)) or mean_unit <= 0:
        raise FormatError("animation frame: a non-finite range or intra unit in the frame head")
    pos = _FRAME_HEAD.size
    if kind == "I":
        pred_int, fdtype = None, dtype
    else:
        if prev is None or (kind == "B" and nxt is None):
            raise FormatError(f"animation frame: a {kind}-frame needs its decoded anchors")
        body, pos = take_section(data, pos, "animation frame")
        if flags & FLAG_GLOBAL:
            if not _global_allowed(s, dtype):
                raise FormatError(
                    f"animation frame: a whole-frame shift in a {dtype} {s.mode} frame"
                )
            vecs, w = decode_global(body, kind == "B", s.search)
            refs = [prev, nxt] if kind == "B" else [prev]
            pred = _global_prediction(refs, vecs, w)
        else:
            field = decode_field(body, motion.block_grid(shape), kind == "B", mean_unit, s.search)
            pred = motion.compensate(
                field, prev, nxt if kind == "B" else None, compensation=s.compensation
            )
        strength = motion.SMOOTHING[(flags & SMOOTH_MASK) >> SMOOTH_SHIFT]
        pred = motion.smooth(pred, strength)
        pred_int = pred if _fused(dtype) else _rounded(pred, dtype)  # see _combine
        fdtype = _residual_dtype(dtype)
    rec = None
    if flags & FLAG_FLAT:
        if s.mode == "coef":
            raise FormatError("animation frame: a flat field in coef mode")
        body, pos = take_section(data, pos, "animation frame")
        rec = decode_flat(body, shape, _flat_step(s, fdtype), fdtype)
    elif flags & FLAG_RESIDUAL:
        try:
            c = _field_codec(s, fdtype, lo, hi, vrange)
        except ValueError as e:
            raise FormatError(f"animation frame: bad coded range ({e})") from None
        rec = np.empty(shape, fdtype)
        for _, sl in bricks.iter_bricks(shape, brick):
            body, pos = take_section(data, pos, "animation frame")
            rec[sl] = c.decode(body, tuple(x.stop - x.start for x in sl), fdtype)
    elif kind != "B":
        raise FormatError(f"animation frame: an {kind}-frame without its coded field")
    out = _combine(pred_int, rec, dtype)
    if flags & FLAG_CORRECTIONS:
        body, pos = take_section(data, pos, "animation frame")
        from ..volume_codec.lossy import apply_corrections

        apply_corrections(body, out, "animation frame")
    if pos != len(data):
        raise FormatError(f"animation frame: {len(data) - pos} stray bytes at the end")
    return kind, out


def _rounded(pred: np.ndarray, dtype: np.dtype) -> np.ndarray:
    """The prediction as the residual is taken from it: rounded and clipped to an
    integer dtype (int64), as is for floats."""
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(pred), info.min, info.max).astype(np.int64)
    return pred


def _precisions(s: Settings) -> tuple[str, ...]:
    """Vector precisions an encoder tries per P/B-frame. Quarter voxels win on sub-voxel
    motion (+10-13 % on the 64^3 moving head and advected field) but lose where half
    voxels already fit (-6 % on the advected field at 128^3, and twice the compensation
    work): so with ``quarter`` the half-voxel field is tried too and the one whose
    residual and vectors cost fewer bits is kept (``coef`` mode keeps the setting)."""
    if s.precision == "quarter" and s.mode != "coef":
        return ("quarter", "half")
    return (s.precision,)


def _choose_smoothing(x: np.ndarray, pred: np.ndarray, s: Settings) -> tuple[int, float]:
    """The strength of :func:`motion.smooth` whose residual, quantised as the coder will
    (bins of 2E + 1, or 1 when lossless), has the least empirical entropy, and that
    entropy in bits; 0 in ``coef`` mode (its bytes do not follow the voxel-domain
    quantisation). The first of equal costs wins, so the choice is deterministic and
    prefers weaker filters."""
    if s.mode == "coef":
        return 0, 0.0
    step = _flat_step(s, x.dtype)
    small = x.dtype.kind in "iu" and x.dtype.itemsize <= 2  # a histogram of every bin
    xf = None if small else x.astype(np.float64)
    best, best_bits = 0, math.inf
    for k in motion.SMOOTHING:
        sm = motion.smooth(pred, k)
        if small:
            bits = _counts_bits(_residual_counts(x, sm, step), x.size)
        else:
            r = xf - _rounded(sm, x.dtype)
            q = np.floor((r + (step - 1) / 2) / step) if x.dtype.kind in "iu" else np.rint(r / step)
            bits = _entropy_bits(q)
        if bits < best_bits:
            best, best_bits = k, bits
    return best, best_bits


@kernel
def _residual_counts_kernel(x, pred, lo, hi, step, base, counts):
    """``counts[q - base] += 1`` for each voxel's quantised residual ``q``: the prediction
    rounded and clipped as :func:`_rounded` does, the bins as :func:`_choose_smoothing`
    (one pass, no temporary frames)."""
    xs, ps = x.ravel(), pred.ravel()
    e = (step - 1.0) / 2.0
    for i in range(xs.size):
        r = np.float64(xs[i]) - min(max(np.rint(ps[i]), lo), hi)
        counts[np.int64(np.floor((r + e) / step)) - base] += 1


def _residual_counts(x: np.ndarray, pred: np.ndarray, step: float) -> np.ndarray:
    """Histogram of the quantised residual of an 8/16-bit integer frame, every bin from
    the lowest possible index (zeros kept)."""
    info = np.iinfo(x.dtype)
    span = float(info.max) - float(info.min)
    base = math.floor((-span + (step - 1) / 2) / step)
    top = math.floor((span + (step - 1) / 2) / step)
    counts = np.zeros(top - base + 1, np.int64)
    _residual_counts_kernel(
        np.ascontiguousarray(x), np.ascontiguousarray(pred, np.float64),
        float(info.min), float(info.max), float(step), base, counts,
    )  # fmt: skip
    return counts


def _counts_bits(counts: np.ndarray, n: int) -> float:
    """Bits of ``n`` symbols with these counts at their empirical order-0 entropy."""
    counts = counts[counts > 0]
    return float(-(counts * np.log2(counts / n)).sum())


def _entropy_bits(q: np.ndarray) -> float:
    """Bits of ``q`` (integer-valued floats) at its empirical order-0 entropy."""
    lo, hi = float(q.min()), float(q.max())
    if hi - lo < 1 << 20:
        counts = np.bincount((q - lo).astype(np.int64).ravel())
    else:
        _, counts = np.unique(q, return_counts=True)
    return _counts_bits(counts, q.size)


def _fused(dtype: np.dtype) -> bool:
    """Whether :func:`_combine` rounds the prediction itself (integers of up to 32 bits)."""
    return dtype.kind in "iu" and dtype.itemsize <= 4


@kernel
def _combine_kernel(pred, rec, lo, hi, out):
    """``out = clip(clip(rint(pred), lo, hi) + rec, lo, hi)`` in one pass (an empty
    ``rec`` adds nothing): :func:`_rounded` and :func:`_combine` for integer frames,
    without their four temporary frames."""
    p, o = pred.ravel(), out.ravel()
    r = rec.ravel()
    for i in range(p.size):
        v = min(max(np.int64(np.rint(p[i])), lo), hi)
        if r.size:
            v = min(max(v + np.int64(r[i]), lo), hi)
        o[i] = v


def _combine(pred_int, rec, dtype: np.dtype) -> np.ndarray:
    """Prediction plus decoded residual, in the frame's dtype (clipped for integers).
    A float64 ``pred_int`` of an integer frame is the prediction before rounding."""
    if pred_int is None:
        return np.ascontiguousarray(rec, dtype=dtype)
    if _fused(dtype) and pred_int.dtype == np.float64:
        info = np.iinfo(dtype)
        out = np.empty(pred_int.shape, dtype)
        r = np.zeros(0, np.int64) if rec is None else np.ascontiguousarray(rec)
        _combine_kernel(np.ascontiguousarray(pred_int), r, int(info.min), int(info.max), out)
        return out
    v = pred_int if rec is None else pred_int + rec
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(v, info.min, info.max).astype(dtype)
    return np.asarray(v, np.float64).astype(dtype)


# -- whole animations -------------------------------------------------------------------


Progress = Callable[[int, int], None]


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
    brick: int | tuple[int, int, int] = bricks.DEFAULT_BRICK,
    search: int = motion.DEFAULT_RADIUS,
    method: str = "fast",
    precision: str = "quarter",
    compensation: str = "windowed",
    b_residual: bool = True,
    whole_frame: bool = True,
    i_max_error: float | None = None,
    force: bool = False,
    progress: Progress | None = None,
    **read_options: Any,
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
    pays (:func:`_tight_pays`).
    """
    from ..format.container import Writer

    if max_error is not None and quality is not None:
        raise OptionError("expected at most one of max_error and quality")
    mode = "bounded" if max_error is not None else "coef" if quality is not None else "lossless"
    src = open_frames(source, **read_options)
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
        i_max_error=i_max_error,
        **{k: v for k, v in inner.items() if v is not None},
    )  # fmt: skip
    _check_dtype(src.dtype, s)
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
        "meta": _jsonable(src.meta),
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
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            raise FormatError(
                f"expected finite voxels in an animation, found NaN or Inf in frame {t}"
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
                anchors[t] = motion.Reference(f.decoded)
            for a in [a for a in anchors if release[a] <= i]:
                del anchors[a]
            yield i, t, x, f

    t0 = time.perf_counter()
    with Writer(_stdout() if target == "-" else target, header, force=force) as w:

        def commit(i: int, t: int, x: np.ndarray, f: CodedFrame) -> None:
            nonlocal lo, hi, sse_total, nbytes
            w.write(t, 0, f.payload, f.max_error)
            flo, fhi = _frame_range(x)
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
        "mb_per_s": raw / 1e6 / max(seconds, 1e-9),
    }


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
    if np.dtype(dtype).kind == "f" and s.mode != "bounded":
        raise FormatError(f"{name} animations are coded with max_error=; found {s.mode} coding")


def _psnr(sse: float, n: int, peak: float) -> float | None:
    if sse == 0 or n == 0:
        return None
    return float(10 * np.log10(max(peak, 1e-300) ** 2 / (sse / n)))


def _summary(rows, src, nbytes, lo, hi, sse_total, s) -> dict[str, Any]:
    nvox = int(np.prod(src.shape[1:]))
    peak = hi - lo
    for r in rows:
        r["psnr"] = _psnr(r.pop("sse"), nvox, peak)
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
        "psnr": _psnr(sse_total, nvox * len(rows), peak),
        "rmse": math.sqrt(sse_total / max(nvox * len(rows), 1)),
        "value_range": [lo, hi],
        "frame_types": counts,
        "scene_cuts": sum(r["type"] == "I" and r["planned"] != "I" for r in rows),
        "block_modes": modes,
        "motion_nbytes": sum(r["motion_nbytes"] for r in rows),
        "frames": rows,
    }


# The per-frame rows are stored by column: on a short series of small frames the JSON
# of one dict per frame (its keys repeated every time) outweighed the frames' data.
MODE_NAMES = ("forward", "backward", "bidirectional", "intra", "global")


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


class AnimationReader:
    """Decode frames of an animation ``.vpk``: one frame with only the anchors it needs
    (:meth:`frame`), all frames (:meth:`frames`), or the playback schedule (:meth:`play`)."""

    def __init__(self, source: Any, *, max_voxels: int = 1 << 34) -> None:
        from ..format.container import Reader

        self._r = source if isinstance(source, Reader) else Reader(source)
        try:
            self.header = check_header(self._r.header, max_voxels)
        except BaseException:
            self._r.close()
            raise
        h = self.header
        self.shape = tuple(h["shape"])
        self.dtype = np.dtype(h["dtype"]).newbyteorder("=")
        self.types = h["types"]
        self.brick = tuple(h["brick"])
        self.settings = Settings.from_header(h)
        self.refs = gop.references(self.types)
        self.decoded = 0  # frames decoded so far (what --frame promises to keep small)

    def close(self) -> None:
        self._r.close()

    def __enter__(self) -> AnimationReader:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

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
        return motion.Reference(frame)

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
        return done[t].frame

    def play(self) -> Iterator[tuple[int, np.ndarray]]:
        """Frames in display order, one decode per step (seekable files)."""
        for t, ref in gop.play(self.types, lambda t, p, n: self._decode(t, self._read(t), p, n)):
            yield t, ref.frame

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
            out[t] = self._decode(t, payload, anchors.get(p), anchors.get(n)).frame
            if self.types[t] in gop.ANCHORS:
                anchors[t] = motion.Reference(out[t])
            for a in [a for a in anchors if release[a] <= i]:
                del anchors[a]
            if progress is not None:
                progress(i + 1, len(order))
        if count != len(order):
            raise FormatError(f"expected {len(order)} frames, found {count}")
        return out


def check_header(hdr: dict, max_voxels: int) -> dict:
    need = ("shape", "dtype", "brick", "types", "codec", "motion", "spacing", "origin")
    if hdr.get("kind") != KIND_ANIMATION or any(k not in hdr for k in need):
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


def decompress(
    source: Any,
    *,
    frame: int | None = None,
    roi: str | tuple[slice, ...] | None = None,
    progress: Progress | None = None,
) -> Volume:
    """Decode an animation ``.vpk`` (a path, bytes, a file or an open container
    Reader): all frames ``(t, z, y, x)``, or one frame decoding only the anchors it
    needs; ``roi`` crops the decoded frames."""
    from ..api import _parse_roi

    with AnimationReader(source) as r:
        data = r.frame(frame) if frame is not None else r.frames(progress)
        h = r.header
    region = _parse_roi(roi, data.shape[-3:])
    data = np.ascontiguousarray(data[(..., *region)]) if roi is not None else data
    origin = tuple(o + s.start * d for o, s, d in zip(h["origin"], region, h["spacing"]))
    return Volume(data, spacing=tuple(h["spacing"]), origin=origin, meta=dict(h.get("meta") or {}))


def _jsonable(meta: dict) -> dict:
    from ..api import _jsonable as j

    return j(meta)


def _stdout():
    import sys

    return sys.stdout.buffer
