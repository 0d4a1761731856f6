"""Mirrored halves: a brick that equals its own mirror image along an axis, coded once.

Volumes computed from a formula on a grid centred on the origin (a hydrogen atom's
probability density, the Marschner-Lobb signal, a simulation started symmetric) are their
own mirror image along one or more axes: slice ``i`` equals slice ``n - 1 - i``. Coded
voxel by voxel, the second half costs as much as the first (a predictor sees no repeat
there; session 37's held-out hydrogen_u8 was 0.684x zstd-19, whose long matches find the
mirrored rows). Here the axes a brick is symmetric along are found, the brick is cut to
its first ``ceil(n / 2)`` slices along each, and the cut brick is coded by the lossless
codec as any (mode 7 of ``formats/lossless-1.md``).
"""

from __future__ import annotations

import numpy as np

from ..errors import FormatError


def _bits(brick: np.ndarray) -> np.ndarray:
    """The stored bits (floats: NaN equals itself, -0.0 differs from 0.0)."""
    return brick.view(f"u{brick.itemsize}") if brick.dtype.kind in "fb" else brick


def find(brick: np.ndarray) -> int:
    """A bit mask of the axes (1: z, 2: y, 4: x) along which ``brick`` equals its mirror
    image; 0 where none (an axis of one slice is never counted)."""
    bits = _bits(brick)
    axes = 0
    for ax in range(3):
        n = bits.shape[ax]
        if n < 2:
            continue
        first = np.take(bits, 0, axis=ax)
        if not np.array_equal(first, np.take(bits, n - 1, axis=ax)):
            continue  # the cheap test first: the outer slices
        if np.array_equal(bits, np.flip(bits, ax)):
            axes |= 1 << ax
    return axes


def shape_of(shape: tuple[int, ...], axes: int) -> tuple[int, ...]:
    """The cut brick's shape: ``ceil(n / 2)`` slices along each mirrored axis."""
    return tuple((n + 1) // 2 if axes >> ax & 1 else n for ax, n in enumerate(shape))


def shrink(brick: np.ndarray, axes: int) -> np.ndarray:
    """The first ``ceil(n / 2)`` slices along each mirrored axis."""
    cut = tuple(slice(0, m) for m in shape_of(brick.shape, axes))
    return np.ascontiguousarray(brick[cut])


def expand(small: np.ndarray, axes: int, shape: tuple[int, ...]) -> np.ndarray:
    """The brick of ``shape`` back from its cut copy: slice ``n - 1 - i`` is slice ``i``."""
    out = small
    for ax, n in enumerate(shape):
        if axes >> ax & 1:
            half = np.take(out, np.arange(n // 2), axis=ax)
            out = np.concatenate((out, np.flip(half, ax)), axis=ax)
    return np.ascontiguousarray(out)


def unpack(data: memoryview, shape: tuple[int, ...] | None = None) -> tuple[int, int]:
    """Read the axes byte for a brick of ``shape`` (None: any shape); returns (axes, 1)."""
    if len(data) < 1:
        raise FormatError("mirrored-halves payload: no axes byte")
    axes = data[0]
    if not 1 <= axes <= 7:
        raise FormatError(f"mirrored-halves payload: expected axes 1 to 7, found {axes}")
    if shape is not None and any(axes >> ax & 1 and n < 2 for ax, n in enumerate(shape)):
        raise FormatError(
            f"mirrored-halves payload: axes {axes} mirror an axis of one slice of {shape}"
        )
    return axes, 1
