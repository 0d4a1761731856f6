"""Background mask: the voxels of a brick that hold its most common value, coded apart.

A skull-stripped or masked scan has a large region of one value (0) around the tissue.
Coded voxel by voxel, that region costs little per voxel, but its border costs much:
each voxel on the edge is a jump the predictor cannot foresee. As a mask, the region's
shape is coded by the label coder (:mod:`.labels`, whose neighbour copies follow a
border cheaply), and the predictor (:mod:`.predictfit`) skips the masked voxels: they
leave no trace in its errors, weights or models. Measured on Colin27 skull-stripped
(``ch2bet``): the mask costs 23 KB and saves 69 KB of prediction (6 % of the file).

Section layout (``formats/lossless-1.md``): ``uleb`` the masked value (in the coded
domain: a value's offset from ``lo``, or a palette rank), ``uleb`` the byte length of
the label stream, the label stream of the mask (2 labels: 1 = masked).
"""

from __future__ import annotations

import numpy as np

from ..errors import FormatError
from . import labels
from . import palette as pal

MIN_SHARE = 0.05  # the encoder tries a mask when the value holds this share of voxels


def choose(values: np.ndarray) -> tuple[int, np.ndarray] | None:
    """The most common value and its mask, when it holds at least MIN_SHARE of the
    brick and not all of it; else None."""
    lo, hi = int(values.min()), int(values.max())
    if hi - lo < pal.DENSE_SPAN:  # counted in a table, not sorted (the same first mode)
        counts = np.bincount((values - lo).reshape(-1), minlength=1)
        k = int(counts.argmax())
        top, fill = int(counts[k]), lo + k
    else:
        vals, counts = np.unique(values, return_counts=True)
        k = int(counts.argmax())
        top, fill = int(counts[k]), int(vals[k])
    if top < MIN_SHARE * values.size or top == values.size:
        return None
    return fill, values == fill


def encode(fill: int, mask: np.ndarray) -> bytes:
    """The mask section: ``fill`` (>= 0, in the coded domain) and the mask's labels."""
    stream = labels.encode(mask.astype(np.int64), 2)
    return pal.uleb(fill) + pal.uleb(len(stream)) + stream


def decode(data: memoryview, shape: tuple[int, int, int], hi: int) -> tuple[int, np.ndarray, int]:
    """Read a mask section at the start of ``data`` (coded values in ``[0, hi]``).
    Returns ``(fill, mask, bytes used)``."""
    fill, pos = pal.read_uleb(data, 0)
    n, pos = pal.read_uleb(data, pos)
    if fill > hi:
        raise FormatError(f"background mask: value {fill} outside the coded range 0..{hi}")
    if pos + n > len(data):
        raise FormatError("background mask: the label stream runs past the payload")
    mask = labels.decode(data[pos : pos + n], shape, 2).astype(bool)
    return fill, mask, pos + n
