"""Repeated slices: a brick whose slices come in equal runs along an axis, coded once a run.

A volume upsampled by nearest neighbour (a label map put on a finer image's grid, a scan
zoomed 2x by copying voxels) repeats each slice ``k`` times along every axis it was
upsampled on. Coded voxel by voxel, each repeat still costs something (the label coder's
copy of the slice above is nearly free, but every border is met ``k`` times and in ``k``
contexts). Here a brick's runs are found per axis, the brick is shrunk to one slice a
run, and the shrunk brick is coded by the lossless codec as any (mode 6 of
``formats/lossless-1.md``).

Along one axis of length ``n`` the runs are described by ``(k, r)``: a first run of
``r`` slices (``1 <= r <= k``), then runs of ``k`` slices, the last one cut at ``n``.
``(1, 1)``: no run. A run may hold slices that equal the next run too (a blank margin);
only the slices where the brick changes must fall on run starts.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import FormatError
from . import palette as pal


def _axis_runs(bits: np.ndarray, axis: int) -> tuple[int, int]:
    """``(k, r)`` of ``bits`` along ``axis``: the longest runs every change falls on."""
    n = bits.shape[axis]
    if n < 2:
        return 1, 1
    x = np.moveaxis(bits, axis, 0).reshape(n, -1)
    starts = np.flatnonzero((x[1:] != x[:-1]).any(axis=1)) + 1  # where a slice changes
    if starts.size == 0:
        return n, n  # (a constant brick is mode 2's; kept general)
    first = int(starts[0])
    if starts.size == 1:
        k = max(first, n - first)
    else:
        k = math.gcd(*(int(d) for d in np.diff(starts)))
    return k, (first - 1) % k + 1


def find(brick: np.ndarray) -> tuple[tuple[int, int], ...] | None:
    """The runs of ``brick`` along z, y and x, or None where no axis repeats. Equality is
    of the stored bits (floats: NaN equals itself, -0.0 differs from 0.0)."""
    bits = brick.view(f"u{brick.itemsize}") if brick.dtype.kind in "fb" else brick
    runs = tuple(_axis_runs(bits, ax) for ax in range(3))
    return None if all(k == 1 for k, _ in runs) else runs


def _starts(n: int, k: int, r: int) -> np.ndarray:
    """The first slice of each run along an axis of ``n`` slices."""
    return np.concatenate(([0], np.arange(r, n, k))) if r < n else np.zeros(1, np.int64)


def shrink(brick: np.ndarray, runs) -> np.ndarray:
    """One slice of each run (the first), along every axis."""
    idx = [_starts(n, k, r) for n, (k, r) in zip(brick.shape, runs)]
    return np.ascontiguousarray(brick[np.ix_(*idx)])


def shape_of(shape: tuple[int, ...], runs) -> tuple[int, ...]:
    """The shrunk brick's shape."""
    return tuple(len(_starts(n, k, r)) for n, (k, r) in zip(shape, runs))


def expand(small: np.ndarray, runs, shape: tuple[int, ...]) -> np.ndarray:
    """The brick of ``shape`` back from its shrunk copy (each slice repeated over its run)."""
    out = small
    for ax, (n, (k, r)) in enumerate(zip(shape, runs)):
        if k > 1:
            starts = _starts(n, k, r)
            out = np.repeat(out, np.diff(np.append(starts, n)), axis=ax)
    return np.ascontiguousarray(out)


def pack(runs) -> bytes:
    """The runs' header: ``k`` and ``r`` of z, y and x, each a uleb."""
    return b"".join(pal.uleb(k) + pal.uleb(r) for k, r in runs)


def unpack(
    data: memoryview, shape: tuple[int, ...] | None = None
) -> tuple[tuple[tuple[int, int], ...], int]:
    """Read the runs' header for a brick of ``shape`` (None: of any shape, as ``info`` and
    the encoder's tiers read a payload's inner mode); returns (runs, bytes used)."""
    runs, pos = [], 0
    for n in shape if shape is not None else (None,) * 3:
        k, pos = pal.read_uleb(data, pos)
        r, pos = pal.read_uleb(data, pos)
        if not 1 <= r <= k or (n is not None and k > max(n, 1)):
            where = f"an axis of {n}" if n is not None else "1 <= r <= k"
            raise FormatError(f"repeated-slice payload: run ({k}, {r}) does not fit {where}")
        runs.append((k, r))
    return tuple(runs), pos
