"""Float wavelets through PyWavelets, as lossy options for comparison with the integer
lifting filters: Daubechies-4 (``d4``, PyWavelets ``db2``), Coiflet-6 (``c6``, ``coif1``)
and CDF 9/7 (``cdf97``, ``bior4.4``).

A brick is transformed with periodic extension (orthonormal for ``d4`` and ``c6``, nearly
so for ``cdf97``), every coefficient is dead-zone quantised with one step (the quality's
orthonormal step, as for the ``coef`` codec), and the integers are coded line by line by
the configured coder. Floats and integers are accepted; there is no error bound.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError, OptionError
from .codec import CODER_NAMES, MODE_CODED, MODE_CONSTANT
from .protocol import BrickCodec, Measured, check_choice, constant_value, from_stored

FLOAT_WAVELETS = {"d4": "db2", "c6": "coif1", "cdf97": "bior4.4"}
MAX_LEVELS = 6


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class FloatWaveletCodec(BrickCodec):
    codec_id: ClassVar[str] = "pywt"
    lossless: ClassVar[bool] = False
    value_range: float
    wavelet: str = "cdf97"
    quality: int | None = None
    step: float | None = None
    coder: str = "arith"

    def __post_init__(self) -> None:
        check_choice("wavelet", self.wavelet, tuple(FLOAT_WAVELETS))
        check_choice("coder", self.coder, CODER_NAMES)
        if (self.quality is None) == (self.step is None):
            raise OptionError("expected exactly one of quality and step")
        if self.quality is not None and not 1 <= int(self.quality) <= 65535:
            raise OptionError(f"expected a quality in 1..65535, found {self.quality!r}")
        if self.step is not None and not 0 < self.step < math.inf:
            raise OptionError(f"expected a positive finite step, found {self.step!r}")
        if not 0 <= self.value_range < math.inf:
            raise OptionError(f"expected a finite value_range >= 0, found {self.value_range!r}")

    @property
    def _delta(self) -> float:
        if self.quality is not None:
            return self.value_range / (int(self.quality) + 1)
        return float(self.step)

    def encode_measured(self, brick: np.ndarray) -> Measured:
        import pywt

        from ..entropy import CODERS
        from ..wavelet import sigmap

        x = np.ascontiguousarray(brick)
        if x.dtype.kind == "f" and not np.isfinite(x).all():
            raise OptionError("float wavelets take finite voxels; use max_error= for NaN/Inf")
        value = constant_value(x)
        if value is not None:
            return Measured(bytes([MODE_CONSTANT]) + value, 0.0, 0.0, x.size)
        arr, _ = _layout(x.shape, self.wavelet)
        coeffs = pywt.wavedecn(
            x.astype(np.float64),
            FLOAT_WAVELETS[self.wavelet],
            mode="periodization",
            level=_levels(x.shape, self.wavelet),
        )
        a, _ = pywt.coeffs_to_array(coeffs)
        q = np.sign(a) * np.floor(np.abs(a) / self._delta + 0.25)
        q = np.ascontiguousarray(q, dtype=np.int64)
        body = CODERS[self.coder].encode(q, sigmap.scan(q.shape, (0, 0, 0), "line"))
        rec = self._rebuild(q, x.shape, x.dtype)
        err = np.abs(rec.astype(np.float64) - x)
        return Measured(
            bytes([MODE_CODED]) + body, float(err.max()), float(np.sum(err * err)), x.size
        )

    def encode(self, brick: np.ndarray) -> bytes:
        return self.encode_measured(brick)[0]

    def _rebuild(self, q: np.ndarray, shape, dtype) -> np.ndarray:
        import pywt

        _, slices = _layout(tuple(shape), self.wavelet)
        a = np.sign(q) * (np.abs(q) + 0.125) * self._delta
        coeffs = pywt.array_to_coeffs(a, slices, output_format="wavedecn")
        v = pywt.waverecn(coeffs, FLOAT_WAVELETS[self.wavelet], mode="periodization")
        v = v[tuple(slice(0, n) for n in shape)]
        if np.dtype(dtype).kind in "iu":
            info = np.iinfo(dtype)
            return np.clip(np.rint(v), info.min, info.max).astype(dtype)
        return v.astype(dtype)

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        from ..entropy import CODERS
        from ..wavelet import sigmap

        dtype = np.dtype(dtype)
        data = memoryview(data)
        if len(data) < 1:
            raise FormatError("empty pywt brick payload: expected at least a mode byte")
        if data[0] == MODE_CONSTANT:
            return np.full(shape, from_stored(data[1:], (1,), dtype)[0], dtype=dtype)
        if data[0] != MODE_CODED:
            raise FormatError(f"pywt brick payload: expected mode 0 or 2, found {data[0]}")
        arr, _ = _layout(tuple(shape), self.wavelet)
        q = np.empty(arr.shape, np.int64)
        CODERS[self.coder].decode(bytes(data[1:]), sigmap.scan(q.shape, (0, 0, 0), "line"), q)
        return self._rebuild(q, shape, dtype)


def _levels(shape, wavelet: str) -> int:
    import pywt

    w = pywt.Wavelet(FLOAT_WAVELETS[wavelet])
    return max(0, min(MAX_LEVELS, *(pywt.dwt_max_level(n, w.dec_len) for n in shape)))


@functools.lru_cache(maxsize=32)
def _layout(shape: tuple[int, ...], wavelet: str):
    """Shape of the coefficient array of a brick and the slices that unpack it."""
    import pywt

    coeffs = pywt.wavedecn(
        np.zeros(shape),
        FLOAT_WAVELETS[wavelet],
        mode="periodization",
        level=_levels(shape, wavelet),
    )
    arr, slices = pywt.coeffs_to_array(coeffs)
    return arr, slices
