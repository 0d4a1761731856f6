"""The brick codec protocol shared by every codec of a volume stream.

A brick codec is a frozen dataclass whose fields are its whole configuration. It has a
``codec_id`` (one id means one byte format for ever, ``formats/wavelet-1.md``), an
``encode(brick) -> bytes`` and a ``decode(data, shape, dtype) -> array``. This base supplies
what every codec would otherwise write again: the config stored in a ``.vpk`` header
(``get_config``), the codec rebuilt from it (``from_config``), and equality, hashing and
``repr`` by config. The codecs themselves are listed in :mod:`.registry`.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from typing import Any, ClassVar, NamedTuple

import numpy as np

from ..errors import FormatError, OptionError


class Measured(NamedTuple):
    """A coded brick and the accuracy the encoder checked on every voxel."""

    payload: bytes
    max_error: float
    sse: float  # sum of squared errors over the valid voxels
    nvalid: int  # voxels that are not NaN, Inf or the fill value


class BrickCodec:
    """Base of the brick codecs: configuration in, bytes out, and back."""

    codec_id: ClassVar[str] = ""
    lossless: ClassVar[bool] = True  # exact on every voxel; lossy codecs say False

    def encode(self, brick: np.ndarray) -> bytes:
        raise NotImplementedError

    def encode_measured(self, brick: np.ndarray) -> Measured:
        """The payload and its accuracy; lossless codecs are exact on every voxel (lossy
        codecs override this and measure)."""
        return Measured(self.encode(brick), 0.0, 0.0, int(np.asarray(brick).size))

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        raise NotImplementedError

    def decode_into(self, data: bytes | memoryview, out: np.ndarray) -> None:
        """Decode a brick of ``out``'s shape and dtype into ``out`` (a view of the volume,
        any strides); codecs that can write there straight skip a copy."""
        out[...] = self.decode(data, out.shape, out.dtype)

    def get_config(self) -> dict[str, Any]:
        """The codec's id and fields: what a ``.vpk`` header stores."""
        return {"id": self.codec_id, **dataclasses.asdict(self)}

    @classmethod
    def from_config(cls, config: Mapping[str, Any]) -> BrickCodec:
        """The codec ``get_config()`` describes; a config that does not fit this codec
        raises FormatError (it comes from a file)."""
        config = dict(config)
        codec_id = config.pop("id", cls.codec_id)
        if codec_id != cls.codec_id:
            raise FormatError(f"expected codec id {cls.codec_id!r}, found {codec_id!r}")
        from ..format.header import dataclass_config

        dataclass_config(cls, config, f"config for codec {cls.codec_id!r}")
        try:
            return cls(**config)
        except (TypeError, ValueError, ArithmeticError) as e:  # OptionError from the checks too
            raise FormatError(f"bad config for codec {cls.codec_id!r}: {e}") from None

    def _key(self) -> str:
        return json.dumps(self.get_config(), sort_keys=True, default=repr)

    def __eq__(self, other: object) -> bool:
        return type(self) is type(other) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._key()))

    def __repr__(self) -> str:
        fields = ", ".join(f"{f.name}={getattr(self, f.name)!r}" for f in dataclasses.fields(self))
        return f"{type(self).__name__}({fields})"


def storage_dtype(dtype: Any) -> np.dtype:
    """Return ``dtype`` in little-endian byte order (how voxels are stored in payloads)."""
    return np.dtype(dtype).newbyteorder("<")


def as_stored(a: np.ndarray) -> bytes:
    """The voxels of ``a`` as payloads store them: little-endian, C order."""
    return np.ascontiguousarray(a, dtype=storage_dtype(a.dtype)).tobytes()


def from_stored(data: bytes | memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    """Voxels stored by :func:`as_stored`, checked to be exactly ``shape`` of ``dtype``."""
    sd = storage_dtype(dtype)
    need = int(np.prod(shape)) * sd.itemsize
    if len(data) != need:
        raise FormatError(
            f"raw brick payload: expected {need} bytes for {shape} {dtype}, found {len(data)}"
        )
    return np.frombuffer(data, dtype=sd).reshape(shape).astype(dtype, copy=True)


def split_mode(data: bytes | memoryview, codec: str) -> tuple[int, memoryview]:
    """A brick payload's leading mode byte and the body after it."""
    data = memoryview(data)
    if len(data) < 1:
        raise FormatError(f"empty {codec} brick payload: expected at least a mode byte")
    return data[0], data[1:]


def as_brick(brick: Any, check_dtype: Any) -> np.ndarray:
    """``brick`` as a 3-D array, its dtype passed by ``check_dtype`` (which raises
    :class:`OptionError`), the start of every codec's ``encode``."""
    brick = np.asarray(brick)
    check_dtype(brick.dtype)
    if brick.ndim != 3:
        raise OptionError(f"expected a 3-D brick, found shape {brick.shape}")
    return brick


def constant_value(brick: np.ndarray) -> bytes | None:
    """The stored bytes of the one value a non-empty brick holds everywhere, else None
    (every codec codes such a brick as its mode-2 payload, a single value)."""
    if brick.size and (brick.flat[0] == brick).all():
        return as_stored(brick.reshape(-1)[:1])
    return None


def check_choice(name: str, value: Any, allowed: tuple[str, ...]) -> None:
    if value not in allowed:
        raise OptionError(f"expected {name} in {allowed}, found {value!r}")
