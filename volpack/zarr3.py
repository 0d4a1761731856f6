"""volpack's wavelet codec as a zarr 3 array-to-bytes codec, on zarr's public interface.

zarr finds it through the ``zarr.codecs`` entry point that ``pip install volpack``
declares (``pyproject.toml``), so a fresh process opens an array written with it without
importing volpack first. Its metadata name is ``volpack.wavelet``; arrays written by the
earlier wrapper of ``zarr.codecs.numcodecs`` (name ``numcodecs.volpack.wavelet``) open too.

    import zarr
    from volpack.zarr3 import VolpackWavelet
    a = zarr.create_array(store, shape=..., chunks=..., dtype="int16",
                          serializer=VolpackWavelet(max_error=0.5), compressors=None)
"""

from __future__ import annotations

import asyncio
from dataclasses import dataclass, field
from typing import Any

from zarr.abc.codec import ArrayBytesCodec
from zarr.core.common import parse_named_configuration
from zarr.registry import register_codec

NAME = "volpack.wavelet"
LEGACY_NAME = "numcodecs.volpack.wavelet"


@dataclass(frozen=True)
class VolpackWavelet(ArrayBytesCodec):
    """Each chunk coded by :class:`volpack.numcodecs.VolpackCodec` (same parameters:
    ``wavelet``, ``coder``, ``order``, ``max_levels``, ``max_error``)."""

    is_fixed_size = False
    config: dict[str, Any] = field(default_factory=dict)

    def __init__(self, **config: Any) -> None:
        from .numcodecs import VolpackCodec

        config.pop("id", None)
        codec = VolpackCodec(**config)  # checks the parameters now, not at the first chunk
        clean = codec.get_config()
        clean.pop("id")
        object.__setattr__(self, "config", clean)

    @property
    def _codec(self):
        from .numcodecs import VolpackCodec

        return VolpackCodec(**self.config)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> VolpackWavelet:
        name, configuration = parse_named_configuration(data, require_configuration=False)
        if name not in (NAME, LEGACY_NAME):
            raise ValueError(f"expected codec name {NAME!r}, found {name!r}")
        return cls(**(configuration or {}))

    def to_dict(self) -> dict[str, Any]:
        return {"name": NAME, "configuration": dict(self.config)}

    async def _decode_single(self, chunk_bytes, chunk_spec):
        out = await asyncio.to_thread(self._codec.decode, chunk_bytes.to_bytes())
        return chunk_spec.prototype.nd_buffer.from_ndarray_like(out.reshape(chunk_spec.shape))

    async def _encode_single(self, chunk_array, chunk_spec):
        blob = await asyncio.to_thread(self._codec.encode, chunk_array.as_ndarray_like())
        return chunk_spec.prototype.buffer.from_bytes(blob)

    def compute_encoded_size(self, input_byte_length: int, chunk_spec) -> int:
        raise NotImplementedError  # variable-size output, as every entropy coder's


def serializer(**config: Any) -> VolpackWavelet:
    """``serializer=`` for ``zarr.create_array`` (zarr format 3)."""
    return VolpackWavelet(**config)


register_codec(NAME, VolpackWavelet)
register_codec(LEGACY_NAME, VolpackWavelet)
