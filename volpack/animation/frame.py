"""One animation frame <-> its chunk: the frame codec.

An I-frame is coded alone by the brick codecs the settings name; a P- or B-frame is
predicted from its decoded anchors (block motion compensation, :mod:`volpack.animation.motion`,
or a whole-frame shift, :mod:`volpack.animation.shift`) and its residual is coded as bricks
or, where that is shorter, as a flat field quantised voxel by voxel. With ``max_error``
every decoded voxel is checked and any voxel past the bound is stored exactly. The
encoder (:func:`encode_frame`) and decoder (:func:`decode_frame`) sit side by side with
the bytes of the motion field and of flat fields; the byte layout is
``formats/animation-1.md``."""

from __future__ import annotations

import dataclasses
import math
import struct

import numpy as np

from .._jit import kernel
from ..errors import FormatError
from ..format.sections import put_section, take_section
from ..volume_codec import bricks
from ..volume_codec.floatbits import from_ordered, to_ordered
from ..volume_codec.specials import fill_masked, special_mask, special_voxels
from . import motion, shift, specials
from .linecode import decode_line, encode_line
from .settings import Settings

# Frame type codes and flag bits (formats/animation-1.md, "Frame payload").
TYPE_CODE = {"I": 0, "P": 1, "B": 2}
TYPE_SPECIALS = 0x10  # type byte bit 4: a section of special voxels follows the frame head
FLAG_RESIDUAL, FLAG_CORRECTIONS, FLAG_FLAT, FLAG_GLOBAL, FLAG_I_BOUND = 1, 2, 4, 0x40, 0x80
SMOOTH_SHIFT, SMOOTH_MASK = 3, 0x38  # flag bits 3-5: index into motion.SMOOTHING
INTRA_CUT = 0.5  # a frame with at least this share of intra blocks is coded as an I-frame
# A whole-frame shift is tried when at least this share of the blocks reading an anchor
# hold a vector within a quarter voxel of their median: the scene moves as one.
COHERENT = 0.5
_FRAME_HEAD = struct.Struct("<BBdddd")  # type, flags, lo, hi, value range, mean unit
MODE_NAMES = ("forward", "backward", "bidirectional", "intra", "global")  # block modes counted


def _field_codec(s: Settings, dtype: np.dtype, lo: float, hi: float, vrange: float):
    """The brick codec for one coded field (a frame or a residual) of ``dtype``."""
    if s.mode == "lossless" and dtype.kind == "f":  # as a 3-D volume's lossless coding
        from ..volume_codec.stream import make_codec

        # An animation stores no codec config: keep the coding it had before version 3.
        if dtype.itemsize > 4:
            return make_codec("zstd")
        return make_codec("auto", dtype, predict_version=2, **s.inner())
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
    c = _field_codec(s, target.dtype, lo, hi, vrange)
    rec = np.empty(target.shape, target.dtype)
    bodies = []
    for _, sl in bricks.iter_bricks(target.shape, brick):
        b = np.ascontiguousarray(target[sl])
        payload = c.encode_measured(b).payload
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
    return encode_line(np.ascontiguousarray(q)), _flat_values(q, step, target.dtype)


def decode_flat(body, shape: tuple[int, ...], step: float, dtype: np.dtype) -> np.ndarray:
    q = decode_line(body, shape)
    if np.abs(q).max(initial=0) >= FLAT_LIMIT:
        raise FormatError("animation frame: a flat field index out of range")
    return _flat_values(q, step, dtype)


def _flat_values(q: np.ndarray, step: float, dtype: np.dtype) -> np.ndarray:
    if dtype.kind in "iu":  # a bin's centre may lie past the dtype's end: clip
        info = np.iinfo(dtype)
        if step > 2**31:  # a header's huge bound: every nonzero bin lies past the range
            return np.clip(q * min(float(step), 2.0**64), info.min, info.max).astype(dtype)
        return np.clip(q * int(step), info.min, info.max).astype(dtype)
    return (q * step).astype(dtype)


def _residual_dtype(dtype: np.dtype, s: Settings) -> np.dtype:
    if dtype.kind == "f":  # lossless: bit patterns' ordered images less the prediction's
        return np.dtype(np.int32 if s.mode == "lossless" else np.float64)
    return np.dtype(np.int16 if dtype.itemsize == 1 else np.int32)


# -- motion field bytes ------------------------------------------------------------------


def encode_field(field: motion.MotionField, two_way: bool, mean_unit: float) -> bytes:
    """The motion field as stacked integer planes (mode, vectors, intra constants),
    coded by the adaptive arithmetic coder in line order."""
    return encode_line(_planes(field, two_way, mean_unit))


def decode_field(
    data: bytes, grid: tuple[int, int, int], two_way: bool, mean_unit: float, radius: int
):
    nf = 8 if two_way else 5
    p = decode_line(data, (nf * grid[0], grid[1], grid[2])).reshape(nf, *grid)
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
    nvalid: int = 0  # voxels neither NaN, Inf nor the fill (the error is theirs)
    value_range: tuple[float, float] = (math.inf, -math.inf)  # of those voxels


def frame_range(x: np.ndarray) -> tuple[float, float]:
    """Smallest and largest finite voxel ((0, 0) if none)."""
    if x.dtype.kind == "f" and not np.isfinite(x).all():
        x = x[np.isfinite(x)]
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
    inline: bool = False,
) -> CodedFrame:
    """Code one frame as ``kind``, or as an I-frame where prediction does not pay: when
    half the blocks or more are intra (a scene cut), or when the predicted frame comes
    out longer than the frame coded alone (both are made and the shorter kept). An
    I-frame that is an ``anchor`` is coded to ``s.i_max_error`` when set. Special voxels
    (NaN, +-Inf, ``s.fill_value``) are filled before anything else sees the frame and
    stored exactly (:mod:`volpack.animation.specials`); a lossless I-frame is also coded
    with them in place (``inline``, as a 3-D volume's lossless coding keeps them) and
    the shorter kept."""
    dtype = x.dtype
    found = special_mask(x, s.fill_value)
    raw, x = x, (x if found is None else fill_masked(x, found))
    lo0, hi0 = frame_range(x)
    mask = None if inline else found
    if inline:
        x = raw
    vrange = hi0 - lo0
    mean_unit = 1.0 if dtype.kind in "iu" else max(vrange / 4096.0, 1e-300)
    field, global_vecs = None, None
    if kind != "I" and not _predictable(s, dtype):
        kind = "I"
    if kind != "I":
        pen = 0.01 * motion.BLOCK**3 * _scale(s, dtype, vrange) ** 2
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
        pred_int = _rounded(smoothed, dtype, s)
        if _bit_residual(s, dtype):
            target = to_ordered(x) - pred_int
            if np.abs(target).max(initial=0) >= 1 << 31:
                return encode_frame(raw, "I", None, None, s, brick, anchor)
        elif dtype.kind in "iu":
            target = x.astype(np.int64) - pred_int
        else:
            target = x.astype(np.float64) - pred_int
        target = target.astype(_residual_dtype(dtype, s))
        if mask is not None:
            target[mask] = 0  # what the decoder puts there is replaced: code nothing
        fdtype = target.dtype
    residual = kind != "B" or s.b_residual
    lo, hi = _planned_range(s, fdtype, *frame_range(target))
    bodies = []
    if residual:
        flags |= FLAG_RESIDUAL
        bodies, rec = _code_bricks(s, target, lo, hi, vrange, brick)
        flat = encode_flat(target, _flat_step(s, fdtype)) if _flat_allowed(s, fdtype) else None
        if flat is not None and len(flat[0]) + 4 < sum(map(len, bodies)):
            flags |= FLAG_FLAT
            bodies, rec = [put_section(flat[0])], flat[1]
        out = _combine(pred_int, rec, dtype, s)
    else:
        out = _combine(pred_int, None, dtype, s)
    with np.errstate(invalid="ignore"):
        err = np.abs(out.astype(np.float64) - x.astype(np.float64))
    if found is not None:
        err[found] = 0.0  # replaced by (or kept as) the special values
    corr = b""
    # rounding to the output dtype pushed these past the bound
    bad = np.flatnonzero(err > s.max_error) if s.mode == "bounded" else np.empty(0, np.int64)
    if guard is not None:  # and a decoder's transform could round these differently
        bad = np.union1d(bad, guard)
    if mask is not None or s.fill_value is not None or dtype.kind == "f":
        # a valid voxel must not decode to a special value (it would read as one)
        lost = special_voxels(out, s.fill_value)
        if found is not None:
            lost &= ~found
        bad = np.union1d(bad, np.flatnonzero(lost))
    if bad.size:
        flags |= FLAG_CORRECTIONS
        out.reshape(-1)[bad] = x.reshape(-1)[bad]
        err.reshape(-1)[bad] = 0.0
        from ..volume_codec.lossy import pack_corrections

        corr = put_section(pack_corrections(x, bad))
    code = TYPE_CODE[kind]
    if mask is not None:
        code |= TYPE_SPECIALS
        ref = prev if kind != "I" else None
        head_parts.insert(0, put_section(specials.encode(raw, mask, ref, s.fill_value)))
        out[mask] = raw[mask]
    head = _FRAME_HEAD.pack(code, flags, lo, hi, vrange, mean_unit)
    payload = b"".join([head, *head_parts, *bodies, corr])
    modes = {} if field is None else dict.fromkeys(MODE_NAMES, 0)
    if global_vecs is not None:
        modes["global"] = int(field.mode.size)
    elif field is not None:
        modes.update(field.counts())
    mnb = len(head_parts[-1]) if field is not None else 0
    nvalid = x.size - (0 if found is None else int(found.sum()))
    coded = CodedFrame(
        payload, out, kind, float(err.max(initial=0.0)), float(np.sum(err * err)), mnb, modes,
        nvalid, (lo0, hi0) if nvalid else (math.inf, -math.inf),
    )  # fmt: skip
    if kind != "I":  # a prediction that costs more than the frame alone is dropped
        alone = encode_frame(raw, "I", None, None, s, brick, anchor)
        if len(alone.payload) < len(payload):
            return alone
    elif mask is not None and s.mode == "lossless":
        kept = encode_frame(raw, "I", None, None, s, brick, anchor, inline=True)
        if len(kept.payload) < len(payload):
            return kept
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
    has_specials, code = bool(code & TYPE_SPECIALS), code & ~TYPE_SPECIALS
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
    if has_specials:
        if dtype.kind != "f" and s.fill_value is None:
            raise FormatError(f"animation frame: special voxels in {dtype} frames without a fill")
        special_body, pos = take_section(data, pos, "animation frame")
    if kind == "I":
        pred_int, fdtype = None, dtype
    else:
        if prev is None or (kind == "B" and nxt is None):
            raise FormatError(f"animation frame: a {kind}-frame needs its decoded anchors")
        if not _predictable(s, dtype):
            raise FormatError(f"animation frame: a {kind}-frame in a lossless {dtype} animation")
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
        pred_int = pred if _fused(dtype) else _rounded(pred, dtype, s)  # see _combine
        fdtype = _residual_dtype(dtype, s)
    rec = None
    if flags & FLAG_FLAT:
        if not _flat_allowed(s, fdtype):
            raise FormatError(f"animation frame: a flat field in a {fdtype} {s.mode} frame")
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
    out = _combine(pred_int, rec, dtype, s)
    if flags & FLAG_CORRECTIONS:
        body, pos = take_section(data, pos, "animation frame")
        from ..volume_codec.lossy import apply_corrections

        apply_corrections(body, out, "animation frame")
    if pos != len(data):
        raise FormatError(f"animation frame: {len(data) - pos} stray bytes at the end")
    if has_specials:
        specials.restore(special_body, out, prev if kind != "I" else None, s.fill_value)
    return kind, out


def _predictable(s: Settings, dtype: np.dtype) -> bool:
    """Whether frames of ``dtype`` may be predicted: not float64 coded losslessly, whose
    ordered bit images do not fit the residual (those frames are coded alone, as a 3-D
    volume's lossless coding would)."""
    return not (s.mode == "lossless" and dtype.kind == "f" and dtype.itemsize > 4)


def _bit_residual(s: Settings, dtype: np.dtype) -> bool:
    """Lossless float frames: the residual is the frame's ordered bit images
    (:mod:`volpack.volume_codec.floatbits`) less the float32 prediction's."""
    return s.mode == "lossless" and dtype.kind == "f"


def _flat_allowed(s: Settings, fdtype: np.dtype) -> bool:
    """Flat fields code integer residuals and bounded float ones, not ``coef`` fields or
    lossless float I-frames."""
    return s.mode != "coef" and not (s.mode == "lossless" and fdtype.kind == "f")


def _scale(s: Settings, dtype: np.dtype, vrange: float) -> float:
    """:meth:`Settings.scale`; for a lossless float frame a 4096th of its range (one unit
    of an integer frame would dwarf most float fields)."""
    if s.mode == "lossless" and dtype.kind == "f":
        return max(vrange, 1e-300) / 4096.0
    return s.scale(vrange)


def _rounded(pred: np.ndarray, dtype: np.dtype, s: Settings | None = None) -> np.ndarray:
    """The prediction as the residual is taken from it: rounded and clipped to an
    integer dtype (int64); for a lossless float frame the ordered image of its float
    (clipped to the finite range); else as is."""
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        return np.clip(np.rint(pred), info.min, info.max).astype(np.int64)
    if s is not None and _bit_residual(s, dtype):
        big = float(np.finfo(dtype).max)
        return to_ordered(np.clip(pred, -big, big).astype(dtype))
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
    if _bit_residual(s, x.dtype):
        o = to_ordered(x)
        bits = [
            _entropy_bits(o - _rounded(motion.smooth(pred, k), x.dtype, s))
            for k in motion.SMOOTHING
        ]
        i = int(np.argmin(bits))
        return motion.SMOOTHING[i], bits[i]
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


def _combine(pred_int, rec, dtype: np.dtype, s: Settings) -> np.ndarray:
    """Prediction plus decoded residual, in the frame's dtype (clipped for integers).
    A float64 ``pred_int`` of an integer frame is the prediction before rounding."""
    if pred_int is None:
        return np.ascontiguousarray(rec, dtype=dtype)
    if _bit_residual(s, dtype):
        v = pred_int if rec is None else pred_int + rec
        if v.min(initial=0) < 0 or v.max(initial=0) >= 1 << (8 * dtype.itemsize):
            raise FormatError("animation frame: a float's bit pattern out of range")
        return from_ordered(v, dtype)
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
