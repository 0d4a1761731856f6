"""Integer fields coded by the adaptive arithmetic coder in line order, without levels:
the motion field, flat residuals and the labels of special voxels of animation frames
(``formats/animation-1.md``). The coder's contexts are the neighbours already coded."""

from __future__ import annotations

import numpy as np


def encode_line(values: np.ndarray) -> bytes:
    from ..entropy import arith
    from ..wavelet import sigmap

    return arith.encode(values, sigmap.scan(values.shape, (0, 0, 0), "line"))


def decode_line(data, shape: tuple[int, ...]) -> np.ndarray:
    """The int64 field of ``shape`` that :func:`encode_line` coded."""
    from ..entropy import arith
    from ..wavelet import sigmap

    out = np.empty(shape, np.int64)
    arith.decode(data, sigmap.scan(shape, (0, 0, 0), "line"), out)
    return out
