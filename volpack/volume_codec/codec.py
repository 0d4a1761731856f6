"""Brick codecs: one brick (a small 3-D array) to bytes and back.

The lossless codecs: the integer wavelet and byte-shuffled zstd. Each is a
:class:`~.protocol.BrickCodec` whose bytes depend only on ``(codec_id, get_config(),
brick)``; :func:`.registry.get_codec` rebuilds any codec from the config stored in a
``.vpk`` header. One ``codec_id`` means one byte format for ever (see
``formats/wavelet-1.md``).

Every wavelet payload starts with a one-byte mode, so a brick that the transform cannot
help (white noise) or that is constant costs at most its raw size plus a byte, or a
few bytes:

====  ===========================================================
mode  payload after the mode byte
====  ===========================================================
0     coefficients coded by the configured entropy coder
1     the raw voxels, little-endian, C order
2     one voxel value (the whole brick is that value), little-endian
3     the voxels as the ``zstd`` codec stores them (byte-shuffled zstd)
====  ===========================================================

Mode 3 serves label maps and segmentations: piecewise-constant bricks whose long runs
of one value a dictionary coder captures far better than a wavelet. It is tried only
on bricks where most voxels equal their x-neighbour, so smooth or noisy data pays
nothing for it.
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError, OptionError
from ..format.deflate import LEVEL as ZSTD_LEVEL
from ..format.deflate import inflate
from .protocol import (
    BrickCodec,
    as_brick,
    as_stored,
    check_choice,
    constant_value,
    from_stored,
    split_mode,
    storage_dtype,
)

# The payload's first byte (formats/wavelet-1.md, section 1).
MODE_CODED, MODE_RAW, MODE_CONSTANT, MODE_ZSTD = 0, 1, 2, 3
PIECEWISE_CONSTANT = 0.5  # share of equal x-neighbours above which mode 3 is tried

WAVELET_NAMES = ("53", "26", "haar", "97m")
CODER_NAMES = ("arith", "arith2", "huffman", "rle", "static", "auto")
ORDER_NAMES = ("dfs", "line")
# Integer dtypes the lossless wavelet path takes exactly (64-bit ones may not fit int64
# intermediates; they go through the zstd codec instead).
WAVELET_DTYPES = ("uint8", "int8", "uint16", "int16", "uint32", "int32")


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class WaveletCodec(BrickCodec):
    """Integer lifting wavelet + significance map + entropy coder (lossless).

    Parameters
    ----------
    wavelet : {"53", "26", "haar", "97m"}
        Reversible lifting filter; 5/3 (CDF 2,2) is the default.
    coder : {"arith", "arith2", "huffman", "rle"}
        Adaptive arithmetic coding (best ratio), the same model as multi-symbol rANS
        (about twice as fast to decode), the fixed Huffman code (fast), or run-length
        Huffman (sparse data).
    order : {"dfs", "line"}
        Coefficient scan: octree depth-first with zero-subtree stripping, or subband by
        subband in raster order.
    max_levels : int or None
        Cap on the decomposition depth per axis; ``None`` lets the brick shape decide.
    """

    codec_id: ClassVar[str] = "wavelet"
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None

    def __post_init__(self) -> None:
        check_choice("wavelet", self.wavelet, WAVELET_NAMES)
        check_choice("coder", self.coder, CODER_NAMES)
        check_choice("order", self.order, ORDER_NAMES)
        if self.max_levels is not None and not (0 <= int(self.max_levels) <= 16):
            raise OptionError(f"expected max_levels in 0..16, found {self.max_levels!r}")

    def _plan(self, shape: tuple[int, ...], dtype: np.dtype):
        from ..wavelet import dwt3

        levels = dwt3.levels_for_shape(shape, self.max_levels)
        info = np.iinfo(dtype)
        work = dwt3.work_dtype(int(info.min), int(info.max), levels, self.wavelet)
        return levels, work

    def encode(self, brick: np.ndarray) -> bytes:
        from ..entropy import CODERS
        from ..wavelet import dwt3, sigmap

        brick = as_brick(brick, check_wavelet_dtype)
        value = constant_value(brick)
        if value is not None:
            return bytes([MODE_CONSTANT]) + value
        raw = as_stored(brick)
        levels, work = self._plan(brick.shape, brick.dtype)
        coeffs = dwt3.forward(brick.astype(work), levels, self.wavelet, overwrite=True)
        scan = sigmap.scan(brick.shape, levels, self.order)
        best = bytes([MODE_CODED]) + CODERS[self.coder].encode(coeffs, scan)
        if piecewise_constant(brick):
            z = bytes([MODE_ZSTD]) + ZstdCodec(level=ZSTD_LEVEL).encode(brick)
            if len(z) < len(best):
                best = z
        if len(best) > len(raw):
            return bytes([MODE_RAW]) + raw
        return best

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        from ..entropy import CODERS
        from ..wavelet import dwt3, sigmap

        dtype = np.dtype(dtype)
        check_wavelet_dtype(dtype)
        mode, body = split_mode(data, "wavelet")
        if mode == MODE_RAW:
            return from_stored(body, shape, dtype)
        if mode == MODE_CONSTANT:
            value = from_stored(body, (1,), dtype)[0]
            return np.full(shape, value, dtype=dtype)
        if mode == MODE_ZSTD:
            return ZstdCodec(level=ZSTD_LEVEL).decode(body, shape, dtype)
        if mode != MODE_CODED:
            raise FormatError(f"wavelet brick payload: expected mode 0 to 3, found {mode}")
        levels, work = self._plan(shape, dtype)
        scan = sigmap.scan(tuple(shape), levels, self.order)
        coeffs = np.empty(shape, dtype=work)
        CODERS[self.coder].decode(bytes(body), scan, coeffs)
        out = dwt3.narrow(dwt3.inverse(coeffs, levels, self.wavelet, overwrite=True), dtype)
        if out is None:
            raise FormatError(
                f"corrupt wavelet brick: decoded values fall outside the {dtype} range"
            )
        return out


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class ZstdCodec(BrickCodec):
    """Byte-shuffled zstd: the exact path for floats and 64-bit integers.

    Shuffling groups the k-th byte of every value together, so the slowly varying high
    bytes (sign, exponent) compress well; NaN and Inf bit patterns are kept as they are.
    """

    codec_id: ClassVar[str] = "zstd"
    level: int = ZSTD_LEVEL
    shuffle: bool = True

    def encode(self, brick: np.ndarray) -> bytes:
        import zstandard

        a = np.ascontiguousarray(brick, dtype=storage_dtype(brick.dtype))
        raw = a.view(np.uint8).reshape(-1, a.dtype.itemsize)
        if self.shuffle and a.dtype.itemsize > 1:
            raw = raw.T
        return zstandard.ZstdCompressor(level=self.level).compress(
            np.ascontiguousarray(raw).tobytes()
        )

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        out = np.empty(tuple(shape), dtype=np.dtype(dtype))
        self.decode_into(data, out)
        return out

    def decode_into(self, data: bytes | memoryview, out: np.ndarray) -> None:
        """The inflated bytes go to ``out`` in one copy (bytes) or one unshuffle and one
        copy (wider voxels)."""
        dtype, n = out.dtype, out.size
        raw = inflate(data, n * dtype.itemsize, "zstd brick payload", exact=True)
        b = np.frombuffer(raw, dtype=np.uint8)
        if self.shuffle and dtype.itemsize > 1:
            b = np.ascontiguousarray(b.reshape(dtype.itemsize, n).T)
        out[...] = b.view(storage_dtype(dtype)).reshape(out.shape)


def piecewise_constant(brick: np.ndarray) -> bool:
    if brick.shape[-1] < 2:
        return False
    same = np.count_nonzero(brick[..., 1:] == brick[..., :-1])
    return same > PIECEWISE_CONSTANT * brick[..., 1:].size


def check_wavelet_dtype(dtype: np.dtype) -> None:
    if np.dtype(dtype).name not in WAVELET_DTYPES:
        if np.dtype(dtype).kind == "f":
            raise FormatError(
                f"the lossless wavelet codec takes integer voxels, found {np.dtype(dtype)}; "
                "use max_error= for error-bounded float coding, or codec='zstd' to store floats exactly"
            )
        raise FormatError(
            f"the wavelet codec takes {', '.join(WAVELET_DTYPES)} voxels, found {np.dtype(dtype)}; "
            "use codec='zstd' for this dtype"
        )
