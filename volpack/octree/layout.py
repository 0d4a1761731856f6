"""Octree geometry, node keys, node payloads and the per-level node table.

Geometry (``formats/octree-1.md`` steps 1-3). ``A_0`` is the volume; ``A_{L+1}`` is
``A_L`` cut into blocks of ``2k`` voxels per axis (edge blocks smaller), each lifted one
level, keeping the low-pass corner, so ``A_L`` has ``ceil(n / 2^L)`` voxels per axis. A
node ``(L, b)`` is the ``k^3`` block ``b`` of ``A_L``; for ``L >= 1`` its chunk holds the
detail coefficients that rebuild its ``(2k)^3`` block of ``A_{L-1}``, i.e. its eight
children. The root (level ``D``, the first level that fits one block) also stores its
low-pass voxels. Level-0 nodes are leaves and have no chunk.

A node's chunk key is ``L << 56 | raster index`` within the level's node grid; the table
of level ``L`` (one row per node: flags, subtree error, deviation range and histogram) is
the chunk ``0xFF << 56 | L``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import numpy as np

from ..errors import FormatError, OptionError
from ..format.sections import put_section, take_section

KIND = "octree"
DEFAULT_BLOCK = 16
# Level tables live at node 0xFF << 56 | L (formats/octree-1.md, "Node tables").
META_TAG = 0xFF
LEVEL_SHIFT = 56
HIST_BINS = 8
# node flags in the level table (formats/octree-1.md, "Node tables")
PRESENT, SUBTREE_ZERO = 1, 2
# payload section flags (formats/octree-1.md, "Chunks")
HAS_DETAILS, HAS_LOWPASS, HAS_CORRECTIONS = 1, 2, 4

META_DTYPE = np.dtype(
    [
        ("flags", "u1"),
        ("E", "<f4"),  # L2 norm of the subtree's normalised detail coefficients
        ("maxdev", "<f4"),  # largest |voxel - node value| over the node's footprint
        ("vmin", "<f4"),
        ("vmax", "<f4"),
        ("hist", "<f4", (HIST_BINS, 2)),  # per value bin: most negative, most positive deviation
    ]
)


@dataclasses.dataclass(frozen=True)
class Geometry:
    """Level shapes and node grids of an octree over a ``(z, y, x)`` volume."""

    shape: tuple[int, int, int]
    block: int

    def __post_init__(self) -> None:
        if len(self.shape) != 3 or min(self.shape) < 1:
            raise FormatError(f"expected a 3-D shape of positive sizes, found {self.shape}")
        if not 2 <= self.block <= 1024:
            raise OptionError(f"expected an octree block of 2..1024 voxels, found {self.block}")

    @property
    def depth(self) -> int:
        """Level of the root: the first level whose voxels fit one block."""
        d, n = 0, list(self.shape)
        while max(n) > self.block:
            n = [(v + 1) // 2 for v in n]
            d += 1
        return d

    def level_shape(self, level: int) -> tuple[int, int, int]:
        return _level_shape(tuple(int(v) for v in self.shape), int(level))

    def grid(self, level: int) -> tuple[int, int, int]:
        return tuple(math.ceil(n / self.block) for n in self.level_shape(level))  # type: ignore[return-value]

    def node_box(self, level: int, b: tuple[int, int, int]) -> tuple[slice, slice, slice]:
        """The node's voxels in ``A_level`` coordinates."""
        return _boxes(tuple(int(v) for v in self.shape), self.block, int(level),
                      (int(b[0]), int(b[1]), int(b[2])))[0]  # fmt: skip

    def footprint(self, level: int, b: tuple[int, int, int]) -> tuple[slice, slice, slice]:
        """The node's region in full-resolution voxels."""
        return _boxes(tuple(int(v) for v in self.shape), self.block, int(level),
                      (int(b[0]), int(b[1]), int(b[2])))[1]  # fmt: skip

    def check_level(self, level: int) -> int:
        d = self.depth
        if not 0 <= int(level) <= d:
            raise FormatError(
                f"expected a level in 0..{d} (0 = full resolution, {d} = the root), found {level}"
            )
        return int(level)


@functools.lru_cache(maxsize=256)  # a walk's selection asks for it tens of thousands of times
def _level_shape(shape: tuple[int, int, int], level: int) -> tuple[int, int, int]:
    n = shape
    for _ in range(level):
        n = tuple((v + 1) // 2 for v in n)
    return n  # type: ignore[return-value]


@functools.lru_cache(maxsize=1 << 16)  # the nodes of a walk's selections, asked each frame
def _boxes(shape, k: int, level: int, b) -> tuple:
    """``(node_box, footprint)`` of node ``(level, b)`` (see :class:`Geometry`)."""
    box = tuple(slice(k * i, min(k * (i + 1), n)) for i, n in zip(b, _level_shape(shape, level)))
    f = 1 << level
    return box, tuple(slice(s.start * f, min(s.stop * f, n)) for s, n in zip(box, shape))


def node_key(level: int, index: int) -> int:
    return (int(level) << LEVEL_SHIFT) | int(index)


def meta_key(level: int) -> int:
    return (META_TAG << LEVEL_SHIFT) | int(level)


def split_key(key: int) -> tuple[int, int]:
    return key >> LEVEL_SHIFT, key & ((1 << LEVEL_SHIFT) - 1)


def lift_levels(shape: tuple[int, ...]) -> tuple[int, int, int]:
    """One level along every axis that has at least two voxels."""
    return tuple(1 if n >= 2 else 0 for n in shape)  # type: ignore[return-value]


def low_shape(shape: tuple[int, ...]) -> tuple[int, int, int]:
    return tuple((n + 1) // 2 for n in shape)  # type: ignore[return-value]


# -- node payloads ---------------------------------------------------------------------


def encode_payload(
    details: bytes | None, lowpass: bytes | None, corrections: bytes | None
) -> bytes:
    """Flag byte, then each present section as ``u32 length + bytes``."""
    flags = 0
    parts = [b""]
    for flag, body in (
        (HAS_DETAILS, details),
        (HAS_LOWPASS, lowpass),
        (HAS_CORRECTIONS, corrections),
    ):
        if body is not None:
            flags |= flag
            parts.append(put_section(body))
    parts[0] = bytes([flags])
    return b"".join(parts)


def decode_payload(data: bytes) -> dict[int, bytes]:
    """Sections of a node payload by flag; raises FormatError on a malformed one."""
    mv = memoryview(data)
    if len(mv) < 1:
        raise FormatError("octree node payload: expected a flag byte, found nothing")
    flags = mv[0]
    if flags & ~(HAS_DETAILS | HAS_LOWPASS | HAS_CORRECTIONS):
        raise FormatError(f"octree node payload: unknown flags {flags:#x}")
    pos, out = 1, {}
    for flag in (HAS_DETAILS, HAS_LOWPASS, HAS_CORRECTIONS):
        if flags & flag:
            out[flag], pos = take_section(mv, pos, "octree node payload")
    if pos != len(mv):
        raise FormatError(f"octree node payload: {len(mv) - pos} stray bytes at the end")
    return out


def encode_table(rows: np.ndarray) -> bytes:
    from ..format.deflate import deflate

    return deflate(np.ascontiguousarray(rows, META_DTYPE).tobytes())


def decode_table(data: bytes, count: int) -> np.ndarray:
    from ..format.deflate import inflate

    raw = inflate(
        data, count * META_DTYPE.itemsize, f"octree level table of {count} nodes", exact=True
    )
    return np.frombuffer(raw, META_DTYPE).copy()


def check_table(rows: np.ndarray, level: int, present: np.ndarray) -> np.ndarray:
    """Refuse a level table whose rows contradict the format or the chunk index.

    ``present`` marks the nodes of the level that have a chunk. Every read of a table goes
    through here, so a damaged table cannot steer a selection or a bound unnoticed.
    """
    what = f"octree level-{level} table"
    flags = rows["flags"]
    if np.any(flags & ~np.uint8(PRESENT | SUBTREE_ZERO)):
        raise FormatError(f"{what}: expected node flags 0 to 3, found {int(flags.max())}")
    if not np.array_equal((flags & PRESENT) != 0, present):
        raise FormatError(f"{what}: the nodes flagged as stored are not those with a chunk")
    e, dev, hist = rows["E"], rows["maxdev"], rows["hist"]
    finite = (
        np.isfinite(e) & np.isfinite(dev) & np.isfinite(rows["vmin"]) & np.isfinite(rows["vmax"])
    )
    if not (finite.all() and np.isfinite(hist).all()):
        raise FormatError(f"{what}: expected finite errors and value ranges")
    if np.any(e < 0) or np.any(dev < 0) or np.any(rows["vmin"] > rows["vmax"]):
        raise FormatError(f"{what}: expected E >= 0, maxdev >= 0 and vmin <= vmax")
    if np.any(hist[..., 0] > 0) or np.any(hist[..., 1] < 0):
        raise FormatError(f"{what}: expected deviation ranges around 0")
    if not np.array_equal(e == 0, (flags & SUBTREE_ZERO) != 0):
        raise FormatError(
            f"{what}: the nodes flagged as all-zero subtrees are not those with E = 0"
        )
    return rows


def detail_energy(c: np.ndarray, lv: tuple[int, int, int], level: int, unit: float) -> float:
    """A node's own share of ``E^2``: ``sum_c (c w_c u 2^(1.5 (level - 1)))^2`` over its
    details ``c`` (low-pass corner zero; ``formats/octree-1.md`` step 7)."""
    from ..wavelet.dwt3 import band_scale

    scale = band_scale(tuple(c.shape), lv).reshape(c.shape)
    norm = unit * 2.0 ** (1.5 * (level - 1))
    return float(np.sum(np.square(c * scale))) * norm * norm


def own_energy_range(e: float, kids: np.ndarray) -> tuple[float, float]:
    """Where a node's own ``E^2`` share lies given its table ``E`` and its children's,
    all rounded up to float32 (the true value is above the next float32 down)."""

    def down(v):
        return np.maximum(np.nextafter(np.float32(v), np.float32(-np.inf)), 0).astype(np.float64)

    e, kids = np.float32(e), np.asarray(kids, np.float32)
    lo = float(down(e)) ** 2 - float(np.sum(kids.astype(np.float64) ** 2))
    hi = float(e) ** 2 - float(np.sum(down(kids) ** 2))
    slack = 1e-9 * float(e) ** 2  # float64 sums in another order
    return lo - slack, hi + slack


def f4_up(x: Any) -> np.ndarray:
    """Round to float32 without going below ``x`` (bounds stay bounds)."""
    x = np.asarray(x, np.float64)
    f = x.astype(np.float32)
    low = f.astype(np.float64) < x
    return np.where(low, np.nextafter(f, np.float32(np.inf)), f).astype(np.float32)
