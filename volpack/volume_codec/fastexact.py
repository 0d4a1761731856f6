"""The exact path of a lossy float brick under ``effort='fast'``: lattices and the fast codec.

Where a float brick's values sit on a coarse lattice (a packed field: ``offset_z + k
step_z`` per z slice), the bounded codec stores it exactly (``formats/lossy-1.md`` step
19). The lossless codec codes the lattice's integers ``k`` by its context-modelled
predictor, a chain of adaptive decisions a voxel (60-70 ns a voxel to decode); this
payload codes them by the ``fast`` codec (MED prediction, static rANS: 7-12 ns a voxel)
and rebuilds the floats in one pass (step 19b):

* the byte :data:`MARK` (6; a ``lossless`` payload starts with its mode, 0-5),
* ``m`` (uleb128): 1, or the brick's z extent (one lattice a slice),
* ``m`` rows of (offset, step) as little-endian f64,
* the length (uleb128) of a ``fast`` payload of ``k`` (an int32 brick), that payload,
* a ``fast`` payload of ``gap`` (int32: the voxels' signed ordered bits less the lattice
  points', as the lossless codec's lattice tool) to the end.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..errors import FormatError
from . import palette as pal
from .fast import MODE_CONSTANT, FastCodec

# The inner section's first byte (a lossless payload's mode byte is 0-5, so the two
# cannot be confused; the quantised voxels' fast payload uses 6 on another path).
MARK = 6

_U = np.uint64
_NO_GAP = bytes([MODE_CONSTANT]) + bytes(4)  # a fast payload of a constant int32 0


def encode(brick: np.ndarray) -> list[bytes]:
    """The payloads of a float brick, one per lattice that the lossless codec's lattice
    tool finds on it (none where its values are on none, or not all finite)."""
    from . import floatpredict as fp

    codec = FastCodec(zstd=False)  # as the quantised voxels': level 19 costs the encoder
    out = []
    for params, k, gap in fp.find_lattices(brick):
        kp = codec.encode(k)
        out.append(
            bytes([MARK])
            + pal.uleb(len(params))
            + params.astype("<f8").tobytes()
            + pal.uleb(len(kp))
            + kp
            + codec.encode(gap)
        )
    return out


def decode(data: bytes | memoryview, shape: tuple[int, int, int], dtype: np.dtype) -> np.ndarray:
    """The brick of an :func:`encode` payload ``data`` (``shape``, float ``dtype``),
    bit for bit."""
    from . import floatpredict as fp

    data = memoryview(data)
    dtype = np.dtype(dtype)
    if len(data) < 2 or data[0] != MARK:
        raise FormatError("fast exact payload: expected its mark byte and a lattice count")
    m, pos = pal.read_uleb(data, 1)
    codec = FastCodec()
    if m not in (1, shape[0]) or pos + 16 * m > len(data):
        raise FormatError(
            f"fast exact payload: expected 1 or {shape[0]} lattices within it, found {m}"
        )
    params = np.frombuffer(data[pos : pos + 16 * m], dtype="<f8").reshape(m, 2)
    n, pos = pal.read_uleb(data, pos + 16 * m)
    if pos + n > len(data):
        raise FormatError("fast exact payload: its k field runs past the payload")
    k = codec.decode(data[pos : pos + n], shape, np.int32)
    rest = data[pos + n :]
    if rest != _NO_GAP:  # (the usual gap, a constant 0, read at no cost)
        gap = codec.decode(rest, shape, np.int32)
        if gap.any():  # voxels off the lattice: the lossless codec's arithmetic
            return fp.apply_lattice(params.astype(np.float64), k, gap, dtype)
    out = np.empty(shape, dtype)
    _lattice(params, k.reshape(shape[0], -1), out.reshape(shape[0], -1))
    return out


@kernel(nrt=False)
def _lattice(rows, k, out):
    """``out[z, i] = dtype(offset_z + step_z * k[z, i])`` in float64, one rounding a
    step and none fused: the same bits as :func:`floatpredict.rebuild`; ``rows``: one
    (offset, step) row, or one a z slice."""
    nz, n = k.shape
    for z in range(nz):
        r = z if rows.shape[0] > 1 else 0
        off = rows[_U(r), 0]
        step = rows[_U(r), 1]
        for i in range(n):
            out[_U(z), _U(i)] = off + step * np.float64(k[_U(z), _U(i)])
