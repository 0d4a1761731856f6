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


# Codecs rebuilt so far, by the repr of their config's items: a header is read twice per
# decode (checked, then used), and its codec's field checks cost more than a small brick's
# Python. repr tells 1, 1.0 and True, and 0.0 and -0.0 apart, so an equal key is a config
# the checks treat alike; a codec is frozen, so one may serve every reader and thread.
# Only what passed is kept, and at most _MAX_MADE of them.
_MADE: dict[tuple, BrickCodec] = {}
_MAX_MADE = 64


def get_codec(config: Mapping[str, Any]) -> BrickCodec:
    """Rebuild a codec from ``get_config()`` output (as stored in a ``.vpk`` header)."""
    if not isinstance(config, Mapping) or "id" not in config:
        raise FormatError(f"expected a codec config with an 'id', found {config!r}")
    key = tuple((k, repr(v)) for k, v in config.items())
    made = _MADE.get(key)
    if made is not None:
        return made
    codec_id = config["id"]
    try:
        cls = CODECS[codec_id]
    except (KeyError, TypeError):
        raise FormatError(f"unknown codec id {codec_id!r}; known: {sorted(CODECS)}") from None
    made = cls.from_config(config)
    if len(_MADE) >= _MAX_MADE:
        _MADE.clear()
    _MADE[key] = made
    return made
