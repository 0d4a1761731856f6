"""``auto``: per coefficient stream, the faster adaptive coder where it costs no ratio.

One byte names the coder of the bytes after it (:data:`CODER_BYTES`). The encoder codes
the coefficients with :mod:`.arith` and :mod:`.arith2` and keeps :mod:`.arith2` (1.6-2x
faster to decode, the same model) unless it is longer. The layout is in
``formats/wavelet-1.md`` (``auto``).

:mod:`.static` (the same model with fixed tables) is not among the choices: on the
wavelet coefficients of four float fields it decoded -1..+17 % faster than
:mod:`.arith2` and was never the shortest (README, "Lossy decoding, part 5"), so it would cost
encoding time and nothing would be gained.
"""

from __future__ import annotations

from ..errors import FormatError
from . import arith, arith2
from .scan import Scan

CODER_BYTES = (arith, arith2)  # the byte before the stream: its coder


def encode(coeffs, scan: Scan) -> bytes:
    """Code a coefficient array (int32 or int64) in ``scan`` order."""
    a = arith.encode(coeffs, scan)
    b = arith2.encode(coeffs, scan)
    return b"\x01" + b if len(b) <= len(a) else b"\x00" + a


def decode(data: bytes, scan: Scan, out) -> None:
    """Decode ``data`` into ``out`` (a C-contiguous int32/int64 array, overwritten)."""
    if len(data) < 1 or data[0] >= len(CODER_BYTES):
        raise FormatError("corrupt auto-coded brick: no coder byte, or an unknown one")
    CODER_BYTES[data[0]].decode(bytes(data[1:]), scan, out)
