"""The ``fast`` brick codec: lossless, decoding at several times the default's speed.

Each brick is coded by :mod:`.fastpredict` (one MED-style prediction and one static
rANS symbol a voxel, or one a run of correctly predicted voxels), on its values or, when the brick leaves values of its range
unused, on their ranks in a palette (:mod:`.palette`); a constant brick is one value,
and a brick that coding cannot shrink is stored raw. The payload's first byte says
which:

====  ==============================================================================
mode  payload after the mode byte
====  ==============================================================================
0     a flags byte (1: palette, 2: float bits), the palette or the value range, then
      the fast stream
1     the voxels, raw, little-endian, C order
2     one voxel value, little-endian: the whole brick has it
3     the voxels as the ``zstd`` codec stores them (byte-shuffled zstd): label maps and
      bricks mostly of one value, where zstd's matches of whole rows and slices code
      about as small as the fast stream and decode ten times faster
====  ==============================================================================

Floats (float16, float32) are coded through the ordered integer image of their bits
(:mod:`.floatbits`), exactly. ``formats/fast-1.md`` gives every byte; ``volpack info``
counts the bricks per mode, predictor and context rule (:func:`describe`).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError, OptionError
from . import palette as pal
from .codec import ZstdCodec
from .floatbits import from_ordered, to_ordered
from .lossless import check_dtype
from .protocol import BrickCodec, as_brick, as_stored, from_stored, split_mode

MODE_CODED, MODE_RAW, MODE_CONSTANT, MODE_ZSTD = 0, 1, 2, 3
FLAG_PALETTE, FLAG_FLOAT = 1, 2
ZSTD_LEVEL = 19  # per 64^3 label brick 1.0-1.6x the bytes' ratio of level 9; 22 adds 1-6 %
# at twice the encode time
ZSTD_SLACK = 0.25  # mode 3 may be longer than the shortest other payload by this share of
ZSTD_RATE = 0.004  # it, and by at most this many bytes a nanosecond of modelled decode time
ZSTD_NS = 1.0  # it saves (fastpredict.decode_ns against ZSTD_NS a voxel byte): 4 KB a
# millisecond, twice the fast codec's own rule, so that every brick of the k-means labels
# switches (1.07-1.19x the bytes, 4x the speed; at 2 KB its largest stays at 2 ms) while
# the ITK T1's bricks (1.09-1.19x the bytes, 1-1.5 ms saved) do not: a share alone cost
# them 13 % of their ratio for no speed, their runs already decode fast
ZSTD_DENSE = 8  # and only where the shortest payload is at most 1/8 of the raw voxels: on
# the noisy bricks of scans (brainsmall, 3:1) the time rule alone cost 1.5 % of the ratio,
# below JPEG-LS's, for 1.15x the speed
ZSTD_PROBE = 3  # a zstd level that costs little: when its frame is over PROBE_SLACK times
PROBE_SLACK = 2.0  # the shortest payload, level 19 is not tried (noisy scan bricks)


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class FastCodec(BrickCodec):
    """Lossless coding that decodes fast: MED / 3-D MED prediction and static rANS.

    It trades ratio for speed against the ``lossless`` codec (no wavelet, no predictor
    blend, no adaptive models); see the README's results for both on the same data.

    Parameters
    ----------
    runs : bool
        Let the encoder code runs of voxels its prediction gets right as run lengths
        (the default: much faster to decode on background and label maps, kept per brick
        when it costs little). ``False`` writes the streams of the files made before the
        run mode, byte for byte (their headers have no ``runs`` field).
    rows : bool
        With the run mode, let the encoder code rows as copies of the row above or of
        the slice above (the default: label maps decode several times faster; kept per
        brick when it costs little). ``False`` writes the streams of the files made
        before it, byte for byte (their headers have no ``rows`` field).
    zstd : bool
        Let the encoder store a brick as byte-shuffled zstd (mode 3) when that is at most
        :data:`ZSTD_SLACK` times the shortest other payload (the default: label maps
        decode about ten times faster). ``False`` writes the payloads of the files made
        before mode 3, byte for byte (their headers have no ``zstd`` field).
    near : bool
        Let the encoder try the ``near`` context rule, kept where it saves
        :data:`.fastpredict.NEAR_GAIN` of the bytes (the default). ``False``: the ``far``
        rule alone, which decodes 10-40 % faster for 1-4 % more bytes (what the bounded
        codec's quantised voxels take under effort 'fast'; encoder only, never in a
        header).
    """

    codec_id: ClassVar[str] = "fast"
    runs: bool = True
    rows: bool = True
    zstd: bool = True
    near: bool = True

    def __post_init__(self) -> None:
        for name in ("runs", "rows", "zstd", "near"):
            if not isinstance(getattr(self, name), bool):
                raise OptionError(f"{name}: expected True or False, found {getattr(self, name)!r}")
        if self.rows and not self.runs:
            object.__setattr__(self, "rows", False)  # the row kinds go with the run mode

    def get_config(self) -> dict[str, Any]:
        """As stored in a header; without the run mode, the row kinds or mode 3 as the
        files before them were."""
        config = super().get_config()
        for name in ("runs", "rows", "zstd"):
            if not config[name]:
                del config[name]
        del config["near"]  # the encoder's freedom: the decoder reads each brick's rule
        return config

    @classmethod
    def from_config(cls, config: Any) -> BrickCodec:
        if isinstance(config, dict):
            config = {"runs": False, "rows": False, "zstd": False, **config}
        return super().from_config(config)

    @staticmethod
    def describe(payload: bytes) -> str:
        """The tool a brick payload used (``volpack info`` counts them)."""
        return describe(payload)

    def encode(self, brick: np.ndarray) -> bytes:
        from . import fastpredict

        brick = as_brick(brick, check_dtype)
        raw = as_stored(brick)
        bits = brick.reshape(-1).view(f"u{brick.itemsize}")
        if brick.size and (bits == bits[0]).all():
            return bytes([MODE_CONSTANT]) + raw[: brick.dtype.itemsize]
        is_float = brick.dtype.kind == "f"
        values = to_ordered(brick) if is_float else brick.astype(np.int64)
        flags = FLAG_FLOAT if is_float else 0
        lo, hi = int(values.min()), int(values.max())
        plain, ranked = {}, {}  # the modelled decode times of the streams
        candidates = [
            (bytes([MODE_RAW]) + raw, {"ns": 0.0}),
            (
                bytes([MODE_CODED, flags])
                + pal.pack_range(lo, hi)
                + fastpredict.encode(values, lo, hi, **self._modes(), report=plain),
                plain,
            ),
        ]
        p = pal.build_span(values, lo, hi)
        if len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
            ranks = pal.to_ranks(values, p)
            candidates.append(
                (
                    bytes([MODE_CODED, flags | FLAG_PALETTE])
                    + pal.pack(p)
                    + fastpredict.encode(ranks, 0, len(p) - 1, **self._modes(), report=ranked),
                    ranked,
                )
            )
        best, report = min(candidates, key=lambda c: len(c[0]))
        if self.zstd:
            saved = report["ns"] - ZSTD_NS * len(raw)
            extra = min(ZSTD_SLACK * len(best), ZSTD_RATE * saved)
            if len(best) * ZSTD_DENSE > len(raw):
                extra = 0.0
            z = _zstd_payload(brick, len(best) + max(extra, 0.0))
            if z is not None:
                return z
        return best

    def _modes(self) -> dict[str, Any]:
        """The encoder's freedom: None lets it measure, False forbids."""
        return {
            "runs": None if self.runs else False,
            "rows": None if self.rows else False,
            "context": None if self.near else "far",
        }

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        dtype = np.dtype(dtype)
        check_dtype(dtype)
        out = np.empty(tuple(shape), dtype=dtype)
        self.decode_into(data, out)
        return out

    def decode_into(self, data: bytes | memoryview, out: np.ndarray) -> None:
        """Decode straight into ``out`` (a brick of the volume): integer voxels go from
        the decoder's work array to ``out`` in one pass, through the palette if any."""
        from . import fastpredict

        dtype = out.dtype
        check_dtype(dtype)
        mode, body = split_mode(data, "fast")
        if mode != MODE_CODED:
            _decode_stored(mode, body, out)
        elif dtype.kind == "f":
            out[...] = _decode_floats(body, out.shape, dtype)
        else:
            values, p, kinds = _decode_integers(body, out.shape, dtype)
            if p is None:
                out[...] = values
            else:  # ranks to voxels to the volume in one pass, copied rows copied
                fastpredict.store_palette(values, p.astype(dtype), out, kinds)


def decode_parts(data: bytes | memoryview, shape: tuple[int, ...], dtype: np.dtype):
    """A payload of integer voxels of ``dtype``, before they are written anywhere:
    ``(values, None, None)``, a 3-D integer array of the voxels (for a coded payload the
    decoder's work array, valid until this thread's next decode, of the smallest type
    that holds the payload's range), or ``(ranks, palette, kinds)``: the voxel is
    ``palette[rank]`` (int64, checked inside ``dtype``'s range) except in the rows
    ``kinds`` marks as copies (:func:`.fastpredict.store_palette`). For a caller that
    maps the integers to other values (the bounded codec's dequantisation): it can map
    each distinct value once and write each voxel once."""
    mode, body = split_mode(data, "fast")
    if mode == MODE_CODED:
        return _decode_integers(body, shape, dtype)
    out = np.empty(shape, dtype)
    _decode_stored(mode, body, out)
    return out, None, None


def _decode_stored(mode: int, body, out: np.ndarray) -> None:
    """Modes 1-3 into ``out``."""
    if mode == MODE_RAW:
        out[...] = from_stored(body, out.shape, out.dtype)
    elif mode == MODE_CONSTANT:
        out[...] = from_stored(body, (1,), out.dtype)[0]
    elif mode == MODE_ZSTD:
        ZstdCodec().decode_into(body, out)
    else:
        raise FormatError(f"fast brick payload: expected mode 0 to 3, found {mode}")


def _coded_head(body, dtype: np.dtype):
    """The flags byte of a mode 0 payload's ``body`` (checked against ``dtype``) and the
    bytes after it."""
    if len(body) < 1:
        raise FormatError("fast brick payload: missing flags byte")
    flags = body[0]
    if flags & ~(FLAG_PALETTE | FLAG_FLOAT) or bool(flags & FLAG_FLOAT) != (dtype.kind == "f"):
        raise FormatError(f"fast brick payload: flags {flags:#x} do not fit {dtype} voxels")
    return flags, body[1:]


def _decode_coded(rest, shape, dtype: np.dtype, flags: int, vmin: int, vmax: int):
    """The values (``palette`` None) or the ranks, palette (checked inside ``[vmin,
    vmax]``) and rows' kinds of a mode 0 payload after its flags byte."""
    from . import fastpredict

    if flags & FLAG_PALETTE:
        p, used = pal.unpack(rest, min(pal.MAX_PALETTE, max(math.prod(shape), 1)))
        if p[0] < vmin or p[-1] > vmax:
            raise FormatError(f"corrupt palette: values outside the range of {dtype}")
        kinds = np.empty(shape[0] * shape[1], np.uint8)
        ranks = fastpredict.decode(rest[used:], shape, 0, len(p) - 1, kinds, reuse=True)
        return ranks, p, kinds
    lo, hi, pos = pal.read_range(rest, vmin, vmax, f"fast brick payload of {dtype}")
    return fastpredict.decode(rest[pos:], shape, lo, hi, reuse=True), None, None


def _decode_integers(body, shape, dtype: np.dtype):
    """:func:`decode_parts` of a mode 0 payload's ``body``."""
    flags, rest = _coded_head(body, dtype)
    if dtype.kind == "b":  # a mask, coded as its 0s and 1s
        return _decode_coded(rest, shape, dtype, flags, 0, 1)
    info = np.iinfo(dtype)
    return _decode_coded(rest, shape, dtype, flags, int(info.min), int(info.max))


def _decode_floats(body, shape, dtype: np.dtype) -> np.ndarray:
    """The voxels of a mode 0 payload's ``body`` of float voxels (coded through their
    ordered bit images)."""
    flags, rest = _coded_head(body, dtype)
    top = (1 << (8 * dtype.itemsize)) - 1
    values, p, _kinds = _decode_coded(rest, shape, dtype, flags, 0, top)
    if p is not None:
        values = pal.from_ranks(values, p)
    return from_ordered(values.astype(np.int64), dtype).reshape(shape)


def _zstd_payload(brick: np.ndarray, limit: float) -> bytes | None:
    """Mode 3's payload when it is at most ``limit`` bytes, else None (level 19 is only
    tried when the quick :data:`ZSTD_PROBE` frame is within :data:`PROBE_SLACK` times)."""
    probe = ZstdCodec(level=ZSTD_PROBE).encode(brick)
    if len(probe) + 1 > PROBE_SLACK * limit:
        return None
    z = bytes([MODE_ZSTD]) + ZstdCodec(level=ZSTD_LEVEL).encode(brick)
    return z if len(z) <= limit else None


def describe(payload: bytes) -> str:
    """The tool a brick payload used, as ``volpack info`` lists it: ``fast-med-far``,
    ``fast-med3d-near+runs+palette``, ... (predictor, context rule, the run mode and
    the palette if any),
    ``raw``, ``constant``, ``zstd``."""
    from .fastpredict import CONTEXTS, PREDICTORS, ROWS, RUNS

    mode = payload[0] if payload else -1
    if mode == MODE_CODED and len(payload) > 2:
        flags = payload[1]
        if flags & FLAG_PALETTE:
            k, pos = pal.read_uleb(memoryview(payload), 2)
            for _ in range(k):
                _, pos = pal.read_uleb(memoryview(payload), pos)
        else:
            _, pos = pal.read_uleb(memoryview(payload), 2)
            _, pos = pal.read_uleb(memoryview(payload), pos)
        b = payload[pos] if pos < len(payload) else 0xFF
        pid, cid = b & 3, (b & ~(RUNS | ROWS)) >> 2
        name = (
            f"{PREDICTORS[pid]}-{CONTEXTS[cid]}"
            if pid < len(PREDICTORS) and cid < len(CONTEXTS)
            else "?"
        )
        return (
            f"fast-{name}"
            + ("+runs" if b & RUNS else "")
            + ("+rows" if b & ROWS else "")
            + ("+palette" if flags & FLAG_PALETTE else "")
        )
    return {1: "raw", 2: "constant", 3: "zstd"}.get(mode, f"mode {mode}")
