"""Every brick codec of a volume stream, by ``codec_id``: the one place a codec is
registered, and the one function that rebuilds a codec from a header's config."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import FormatError
from .codec import WaveletCodec, ZstdCodec
from .fast import FastCodec
from .floatwave import FloatWaveletCodec
from .lossless import LosslessCodec
from .lossy import BoundedCodec, CoefCodec
from .protocol import BrickCodec
from .tucker import TuckerCodec

CODECS: dict[str, type[BrickCodec]] = {
    c.codec_id: c
    for c in (
        WaveletCodec,
        ZstdCodec,
        LosslessCodec,
        BoundedCodec,
        CoefCodec,
        FloatWaveletCodec,
        FastCodec,
        TuckerCodec,
    )
}


def get_codec(config: Mapping[str, Any]) -> BrickCodec:
    """Rebuild a codec from ``get_config()`` output (as stored in a ``.vpk`` header)."""
    if not isinstance(config, Mapping) or "id" not in config:
        raise FormatError(f"expected a codec config with an 'id', found {config!r}")
    codec_id = config["id"]
    try:
        cls = CODECS[codec_id]
    except (KeyError, TypeError):
        raise FormatError(f"unknown codec id {codec_id!r}; known: {sorted(CODECS)}") from None
    return cls.from_config(config)
