"""Coefficient coders: a wavelet coefficient array plus its scan to bytes, and back.

Each coder module has ``encode(coeffs, scan) -> bytes`` and ``decode(data, scan, out)``:

``arith``
    significance map + adaptive binary arithmetic coding (best ratio);
``arith2``
    the same model as adaptive multi-symbol rANS (about twice as fast to decode, a
    fraction of a percent larger);
``static``
    the same model with static rANS tables stored per stream (no adaptation; the
    tables cost bytes, and it decodes -1..+17 % faster than ``arith2``);
``auto``
    per stream, ``arith2`` unless ``arith`` is shorter (a byte names the coder): the
    error-bounded codec's default;
``huffman``
    significance map + the fixed prefix code (about ten times faster to decode);
``rle``
    zero runs + the fixed prefix code (for sparse, very lossy coefficients).
"""

from __future__ import annotations

from types import SimpleNamespace

from . import arith, arith2, choose, fixed, static

CODERS = {
    "arith": arith,
    "arith2": arith2,
    "static": static,
    "auto": choose,
    "huffman": SimpleNamespace(encode=fixed.encode_huffman, decode=fixed.decode_huffman),
    "rle": SimpleNamespace(encode=fixed.encode_rle, decode=fixed.decode_rle),
}
