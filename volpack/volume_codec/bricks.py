"""The brick grid: how a volume is cut into independent bricks, and back.

Bricks are numbered in raster order over the brick grid (z slowest, x fastest). That
number is the ``node`` of the brick's ``.vpk`` chunk; ``t`` is the time step.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator

import numpy as np

from ..errors import FormatError, OptionError

DEFAULT_BRICK = 64
# Scan tables index a brick's coefficients with 32-bit integers.
MAX_BRICK_VOXELS = 1 << 30
# Float volumes under an error bound: the float wavelet codes long extents better (many
# levels, no brick edges), so up to this many voxels the volume is one brick, else
# LOSSY_FLOAT_BRICK^3 (a brick's scan tables take ~25 bytes a voxel).
LOSSY_FLOAT_VOXELS = 1 << 22
LOSSY_FLOAT_BRICK = 128
# ... except a thin one (THIN_SLICES) past that size: its bricks hold the whole depth and a
# square of side the largest power of two with at most LOSSY_FLOAT_VOXELS voxels (z = 1:
# 2048, 4: 1024, 16: 512), as for the lossless thin bricks below: 128^3 would cut a 2-D
# field into 128^2 tiles, each predicted and coded without its neighbours. Measured
# (session 34, results/lossy/flat34): a 1201x2401 topography coded whole was 1.23x,
# 1.06x, 1.16x, 1.15x shorter than in 128^2 tiles at 1e-2..1e-5 of its range.
# Float volumes coded exactly by the default codec: its tools (float Lorenzo, lattices,
# byte-shuffled zstd) gain from long extents too, zstd most (matches across what would be
# brick edges); measured 0 to +7.4 % ratio on 21 float fields against 64^3. The Lorenzo
# workspace is 32 bytes a voxel, 64 MB for such a brick.
LOSSLESS_FLOAT_BRICK = 128
# Small integer volumes coded exactly by the default codec: each brick learns its models
# and stores its fitted predictor from nothing, which a brick of a small noisy scan pays
# for in a larger share; up to this many voxels the bricks are LOSSLESS_SMALL_BRICK^3.
# Measured against 64^3 (issue 20): +1.6 % ratio on the dipy b0 slab, +1.3 % on the EPI
# volume, +0.9 % on the ITK T1, +0.5 % on brainsmall, -0.01 % (7 header bytes) on the
# StarDist stack. Larger volumes keep 64^3 (not measured: minutes of encoding each).
LOSSLESS_SMALL_VOXELS = 1 << 21
LOSSLESS_SMALL_BRICK = 128
# Thin integer volumes (at most THIN_SLICES slices, wider than a brick) coded exactly by
# the default codec: a brick holds the whole depth and a square of side the largest power
# of two with at most THIN_VOXELS voxels (z = 1: 1024, 8: 256), so its models and fitted
# predictor learn from whole slices, not from 128^2 or 64^2 tiles of a few slices.
# Measured (session 33, results/lossless/thin33): one CT slice +1.8 % ratio against
# 128^2 tiles, a 12x1024x1024 microscopy stack +1.1 % against 64^3.
THIN_SLICES = 16
THIN_VOXELS = 1 << 20


def default_brick(
    shape: tuple[int, ...], dtype, bounded: bool, codec: str | None = None, lossy: bool = False
) -> tuple[int, int, int]:
    """The brick used when none is asked for: DEFAULT_BRICK; for a float volume under an
    error bound (``bounded``) the whole volume if it is small, else bricks of its whole
    depth if it is thin (:func:`thin_brick`), else LOSSY_FLOAT_BRICK; for
    a float volume coded exactly by the default codec (``codec`` ``"auto"`` or
    ``"lossless"``), LOSSLESS_FLOAT_BRICK; for a small integer volume coded exactly by it
    (no ``lossy`` setting), LOSSLESS_SMALL_BRICK, and for a thin one (THIN_SLICES) wider
    than that, bricks of its whole depth (:func:`thin_brick`)."""
    spatial = tuple(int(n) for n in shape[-3:])
    exact = codec in ("auto", "lossless")
    if np.dtype(dtype).kind != "f":
        small = math.prod(spatial) <= LOSSLESS_SMALL_VOXELS
        side = LOSSLESS_SMALL_BRICK if exact and not lossy and small else DEFAULT_BRICK
        if exact and not lossy and 0 < spatial[0] <= THIN_SLICES and max(spatial[1:]) > side:
            return thin_brick(spatial[0])
        return (side,) * 3
    if not bounded:
        side = LOSSLESS_FLOAT_BRICK if exact else DEFAULT_BRICK
        return (side,) * 3
    if math.prod(spatial) <= LOSSY_FLOAT_VOXELS:
        return tuple(max(1, n) for n in spatial)  # type: ignore[return-value]
    if spatial[0] <= THIN_SLICES:
        return thin_brick(spatial[0], LOSSY_FLOAT_VOXELS)
    return (LOSSY_FLOAT_BRICK,) * 3


def thin_brick(nz: int, voxels: int = THIN_VOXELS) -> tuple[int, int, int]:
    """The brick of a thin volume of ``nz`` slices: ``(nz, s, s)``, ``s`` the largest power
    of two with ``nz * s * s <= voxels`` (THIN_VOXELS, for integers coded exactly: 256 from
    16 slices down to 5)."""
    s = 1 << (int(math.isqrt(voxels // nz)).bit_length() - 1)
    return (nz, s, s)


def parse_brick(value: int | tuple[int, ...] | list[int]) -> tuple[int, int, int]:
    """Return a brick size ``(bz, by, bx)`` from an int or three ints, each >= 1."""
    if isinstance(value, (int, np.integer)):
        t = (int(value),) * 3
    else:
        t = tuple(int(v) for v in value)
    if len(t) != 3 or min(t) < 1 or max(t) > 4096:
        raise OptionError(
            f"expected a brick size of 1..4096 per axis (one number or z,y,x), found {value!r}"
        )
    if math.prod(t) > MAX_BRICK_VOXELS:
        raise OptionError(
            f"expected a brick of at most {MAX_BRICK_VOXELS} voxels (1024^3), found {t}"
        )
    return t  # type: ignore[return-value]


def grid_shape(shape: tuple[int, ...], brick: tuple[int, int, int]) -> tuple[int, int, int]:
    """Number of bricks along each spatial axis."""
    return tuple(max(1, math.ceil(n / b)) for n, b in zip(shape[-3:], brick))  # type: ignore[return-value]


def brick_slices(
    shape: tuple[int, ...], brick: tuple[int, int, int], node: int
) -> tuple[slice, slice, slice]:
    """The region of brick number ``node`` (edge bricks are smaller, never padded)."""
    g = grid_shape(shape, brick)
    if not 0 <= node < math.prod(g):
        raise FormatError(f"expected a brick number in 0..{math.prod(g) - 1}, found {node}")
    zy, x = divmod(int(node), g[2])  # (np.unravel_index: 2-3 us, once a brick decoded)
    z, y = divmod(zy, g[1])
    return tuple(
        slice(i * b, min((i + 1) * b, n)) for i, b, n in zip((z, y, x), brick, shape[-3:])
    )  # type: ignore[return-value]


def iter_bricks(
    shape: tuple[int, ...], brick: tuple[int, int, int]
) -> Iterator[tuple[int, tuple[slice, slice, slice]]]:
    """Yield ``(node, slices)`` for every brick in node order."""
    g = grid_shape(shape, brick)
    for node, idx in enumerate(itertools.product(*(range(n) for n in g))):
        yield (
            node,
            tuple(slice(i * b, min((i + 1) * b, n)) for i, b, n in zip(idx, brick, shape[-3:])),
        )


def bricks_in_roi(
    shape: tuple[int, ...], brick: tuple[int, int, int], roi: tuple[slice, slice, slice]
) -> list[int]:
    """Numbers of the bricks that intersect the region ``roi`` (slices with step 1)."""
    g = grid_shape(shape, brick)
    ranges = []
    for s, b, n, gn in zip(roi, brick, shape[-3:], g):
        start, stop, step = s.indices(n)
        if step != 1:
            raise OptionError(f"expected a region with step 1, found {s}")
        if stop <= start:
            return []
        ranges.append(range(start // b, min(gn, (stop - 1) // b + 1)))
    # raster order by arithmetic (np.ravel_multi_index cost 5 us a brick, a small field's
    # decode reads one)
    return [(z * g[1] + y) * g[2] + x for z, y, x in itertools.product(*ranges)]
