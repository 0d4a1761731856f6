"""The ``lossless`` brick codec: each brick coded by the tool that suits it.

The wavelet codec (:mod:`.codec`) suits smooth, noisy scans; a sharp edge against
a flat background (skull-stripped MRI), a sparse histogram (rescaled scans) or floats
suit 3-D prediction (:mod:`.predict`) better. This codec tries the tools on every
brick and keeps the shortest payload, so a volume gets what each of its bricks needs.
The payload's first byte says what was chosen:

====  ===============================================================================
mode  payload after the mode byte
====  ===============================================================================
0-3   as the ``wavelet`` codec's modes (coefficients, raw, constant, byte-shuffled zstd)
4     3-D prediction: a flags byte (1: palette, 2: float bits, 4: floats split into
      exponent and mantissa, 8: labels copied from neighbours), then the palette or the
      value range (none when split), then the predictive or label stream
====  ===============================================================================

Floats (float16, float32) are coded exactly through the ordered integer image of their
bits (:mod:`.floatbits`); NaN, -0.0, denormals and Inf come back bit for bit.
``formats/lossless-1.md`` gives every byte. ``volpack info`` reports how many bricks
took each tool (:func:`describe`).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError
from . import palette as pal
from .codec import (
    MODE_CONSTANT,
    MODE_RAW,
    MODE_ZSTD,
    WAVELET_DTYPES,
    WaveletCodec,
    ZstdCodec,
    piecewise_constant,
)
from .floatbits import FLOAT_DTYPES, from_ordered, to_ordered
from .protocol import BrickCodec, as_brick, split_mode
from .protocol import as_stored as _as_stored
from .protocol import check_choice as _check_choice
from .protocol import from_stored as _from_stored

MODE_PREDICT = 4
FLAG_PALETTE, FLAG_FLOAT, FLAG_SPLIT, FLAG_LABELS = 1, 2, 4, 8
TOOLS = ("auto", "wavelet", "predict")
FLOAT_ZSTD_LEVEL = 9


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class LosslessCodec(BrickCodec):
    """Per-brick choice of wavelet coding or 3-D prediction (with a palette), lossless.

    Parameters
    ----------
    wavelet, coder, order, max_levels
        Settings of the wavelet tool (see :class:`volpack.codec.WaveletCodec`).
    tools : {"auto", "wavelet", "predict"}
        ``auto`` tries both tools on every brick and keeps the shorter; the others use
        one tool (for comparison; floats always use prediction).
    """

    codec_id: ClassVar[str] = "lossless"
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None
    tools: str = "auto"

    def __post_init__(self) -> None:
        _check_choice("tools", self.tools, TOOLS)
        self._wavelet_codec()  # checks the wavelet settings

    @staticmethod
    def describe(payload: bytes) -> str:
        """The tool a brick payload used (``volpack info`` counts them)."""
        return describe(payload)

    def _wavelet_codec(self) -> WaveletCodec:
        return WaveletCodec(self.wavelet, self.coder, self.order, self.max_levels)

    def encode(self, brick: np.ndarray) -> bytes:
        brick = as_brick(brick, check_dtype)
        raw = _as_stored(brick)
        flat = brick.reshape(-1)
        bits = flat.view(f"u{brick.itemsize}")
        if brick.size and (bits == bits[0]).all():
            return bytes([MODE_CONSTANT]) + raw[: brick.dtype.itemsize]
        is_float = brick.dtype.kind == "f"
        candidates = [bytes([MODE_RAW]) + raw]
        if is_float:
            z = ZstdCodec(level=FLOAT_ZSTD_LEVEL).encode(brick)
            candidates.append(bytes([MODE_ZSTD]) + z)
        elif self.tools != "predict":
            candidates.append(self._wavelet_codec().encode(brick))
        if is_float or self.tools != "wavelet":
            candidates += _encode_predict(brick)
        return min(candidates, key=len)

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        dtype = np.dtype(dtype)
        check_dtype(dtype)
        mode, body = split_mode(data, "lossless")
        if mode == MODE_PREDICT:
            return _decode_predict(body, tuple(shape), dtype)
        if dtype.kind != "f":
            if mode > MODE_ZSTD:
                raise FormatError(f"lossless brick payload: expected mode 0 to 4, found {mode}")
            return self._wavelet_codec().decode(data, shape, dtype)
        if mode == MODE_RAW:
            return _from_stored(body, shape, dtype)
        if mode == MODE_CONSTANT:
            return np.full(shape, _from_stored(body, (1,), dtype)[0], dtype=dtype)
        if mode == MODE_ZSTD:
            return ZstdCodec(level=FLOAT_ZSTD_LEVEL).decode(body, shape, dtype)
        raise FormatError(f"lossless float brick payload: expected mode 1 to 4, found {mode}")


def check_dtype(dtype: np.dtype) -> None:
    name = np.dtype(dtype).name
    if name not in WAVELET_DTYPES and name not in FLOAT_DTYPES:
        raise FormatError(
            f"the lossless codec takes {', '.join(WAVELET_DTYPES + FLOAT_DTYPES)} voxels, "
            f"found {np.dtype(dtype)}; use codec='zstd' for this dtype"
        )


def describe(payload: bytes) -> str:
    """The tool a brick payload used, as ``volpack info`` lists it."""
    mode = payload[0] if payload else -1
    if mode == MODE_PREDICT and len(payload) > 1:
        if payload[1] & FLAG_SPLIT:
            return "predict-float"
        if payload[1] & FLAG_LABELS:
            return "labels"
        return "predict+palette" if payload[1] & FLAG_PALETTE else "predict"
    return {0: "wavelet", 1: "raw", 2: "constant", 3: "zstd"}.get(mode, f"mode {mode}")


def _encode_predict(brick: np.ndarray) -> list[bytes]:
    """Predictive payloads of a brick: on its values, and on their ranks when the brick
    leaves values of its range unused."""
    from . import predict

    is_float = brick.dtype.kind == "f"
    values = to_ordered(brick) if is_float else brick.astype(np.int64)
    flags = FLAG_FLOAT if is_float else 0
    lo, hi = int(values.min()), int(values.max())
    if is_float:  # exponent and mantissa apart: whole images leap at binade changes
        from . import floatcode

        out = [bytes([MODE_PREDICT, flags | FLAG_SPLIT]) + floatcode.encode(values, brick.itemsize)]
    else:
        out = [
            bytes([MODE_PREDICT, flags])
            + pal.uleb(_zigzag(lo))
            + pal.uleb(hi - lo)
            + predict.encode(values, lo, hi)
        ]
    if hi - lo + 1 > 2:
        p = pal.build(values)
        if len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
            ranks = pal.to_ranks(values, p)
            out.append(
                bytes([MODE_PREDICT, flags | FLAG_PALETTE])
                + pal.pack(p)
                + predict.encode(ranks, 0, len(p) - 1)
            )
    if piecewise_constant(brick):
        from . import labels

        p = pal.build(values)
        if len(p) <= pal.MAX_PALETTE:
            out.append(
                bytes([MODE_PREDICT, flags | FLAG_PALETTE | FLAG_LABELS])
                + pal.pack(p)
                + labels.encode(pal.to_ranks(values, p), len(p))
            )
    return out


def _decode_predict(body: memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    from . import predict

    if len(body) < 1:
        raise FormatError("predictive brick payload: missing flags byte")
    flags = body[0]
    is_float = dtype.kind == "f"
    split = bool(flags & FLAG_SPLIT)
    if (
        flags & ~(FLAG_PALETTE | FLAG_FLOAT | FLAG_SPLIT | FLAG_LABELS)
        or bool(flags & FLAG_FLOAT) != is_float
        or (split and flags & (FLAG_PALETTE | FLAG_LABELS))
        or (split and not is_float)
        or (flags & FLAG_LABELS and not flags & FLAG_PALETTE)
    ):
        raise FormatError(f"predictive brick payload: flags {flags:#x} do not fit {dtype} voxels")
    vmin, vmax = _value_range(dtype)
    rest = body[1:]
    n = int(np.prod(shape))
    if split:
        from . import floatcode

        values = floatcode.decode(rest, shape, dtype.itemsize)
    elif flags & FLAG_PALETTE:
        p, used = pal.unpack(rest, min(pal.MAX_PALETTE, max(n, 1)))
        if p[0] < vmin or p[-1] > vmax:
            raise FormatError(f"corrupt palette: values outside the range of {dtype}")
        if flags & FLAG_LABELS:
            from . import labels

            ranks = labels.decode(rest[used:], shape, len(p))
        else:
            ranks = predict.decode(rest[used:], shape, 0, len(p) - 1)
        values = pal.from_ranks(ranks, p)
    else:
        z, pos = pal.read_uleb(rest, 0)
        span, pos = pal.read_uleb(rest, pos)
        lo = (z >> 1) ^ -(z & 1)
        if lo < vmin or lo + span > vmax:
            raise FormatError(
                f"predictive brick payload: value range [{lo}, {lo + span}] outside {dtype}"
            )
        values = predict.decode(rest[pos:], shape, lo, lo + span)
    if is_float:
        return from_ordered(values, dtype).reshape(shape)
    return values.astype(dtype).reshape(shape)


def _value_range(dtype: np.dtype) -> tuple[int, int]:
    """The integers a voxel of ``dtype`` maps to (floats: their ordered bit images)."""
    if dtype.kind == "f":
        return 0, (1 << (8 * dtype.itemsize)) - 1
    info = np.iinfo(dtype)
    return int(info.min), int(info.max)


def _zigzag(v: int) -> int:
    return (v << 1) if v >= 0 else ((-v) << 1) - 1
