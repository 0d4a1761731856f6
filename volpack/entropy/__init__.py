"""Coefficient coders: a wavelet coefficient array plus its scan to bytes, and back.

Each coder module has ``encode(coeffs, scan) -> bytes`` and ``decode(data, scan, out)``:

``arith``
    significance map + adaptive binary arithmetic coding (best ratio);
``huffman``
    significance map + the fixed prefix code (about ten times faster to decode);
``rle``
    zero runs + the fixed prefix code (for sparse, very lossy coefficients).
"""

from __future__ import annotations

from types import SimpleNamespace

from . import arith, fixed

CODERS = {
    "arith": arith,
    "huffman": SimpleNamespace(encode=fixed.encode_huffman, decode=fixed.decode_huffman),
    "rle": SimpleNamespace(encode=fixed.encode_rle, decode=fixed.decode_rle),
}
