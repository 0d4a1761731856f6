"""Value palettes: a brick's distinct values replaced by their ranks, and back.

A rescaled or resampled scan, or a skull-stripped one, often uses few of the values its
dtype allows (an 8-bit MRI with 81 levels; a 12-bit scan scaled by 16 uses every 16th
value). A predictor working on the ranks ``0..K-1`` sees the steps between used values
as steps of one, so a jump of 51 grey levels at the brain's edge, or a constant stride,
costs no more than a step of one.

The palette is stored as ``K`` (unsigned LEB128), the smallest value (signed: zig-zag,
then LEB128) and the ``K - 1`` gaps between consecutive values less one (LEB128 each);
see ``formats/lossless-1.md``.
"""

from __future__ import annotations

import numpy as np

from ..errors import FormatError

MAX_PALETTE = 1 << 16  # a palette beyond this costs more than it can save


def build(values: np.ndarray) -> np.ndarray:
    """The sorted distinct values of ``values`` (int64)."""
    return sorted_unique(np.asarray(values, dtype=np.int64))


def sorted_unique(values: np.ndarray) -> np.ndarray:
    """``np.unique(values)`` of integers or finite floats, by a sort: numpy 2.3's hash table is 15x slower than a sort on
    a float brick's 2M distinct values (and at most 2x faster on few)."""
    s = np.sort(values, axis=None)
    keep = np.empty(s.size, dtype=bool)
    keep[:1] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


DENSE_SPAN = 1 << 22  # a value range this narrow is mapped through a table, not sorted


def to_ranks(values: np.ndarray, palette: np.ndarray) -> np.ndarray:
    """Each value's index in ``palette`` (which holds every value): over a narrow range,
    one look-up a value in a table of ranks (a 64^3 brick: 32x faster than a binary
    search on 8-bit values, 48x on 12-bit, 10x on 20-bit; untouched pages cost nothing)."""
    values = np.asarray(values, dtype=np.int64)
    if not palette.size or int(palette[-1]) - int(palette[0]) >= DENSE_SPAN:
        return np.searchsorted(palette, values).astype(np.int64)
    lo = int(palette[0])
    rank = np.zeros(int(palette[-1]) - lo + 1, dtype=np.int64)
    rank[palette - lo] = np.arange(len(palette))
    return rank[values - lo]


def build_span(values: np.ndarray, lo: int, hi: int) -> np.ndarray:
    """:func:`build` of int64 ``values`` known to lie in ``[lo, hi]``: over a narrow range,
    one pass marking the values seen (a head CT brick: 10 ms of hashing and sorting)."""
    if hi - lo >= DENSE_SPAN:
        return build(values)
    seen = np.zeros(hi - lo + 1, dtype=bool)
    seen[values.reshape(-1) - lo] = True
    return np.flatnonzero(seen).astype(np.int64) + lo


def from_ranks(ranks: np.ndarray, palette: np.ndarray) -> np.ndarray:
    """The values of ``ranks`` (each in ``0..len(palette)-1``, checked by the caller)."""
    return palette[ranks]


def pack(palette: np.ndarray) -> bytes:
    """The bytes of a palette (strictly increasing int64 values, at least one)."""
    gaps = np.diff(palette) - 1
    first = int(palette[0])
    return uleb(len(palette)) + uleb((first << 1) ^ (first >> 63)) + uleb_many(gaps)


def uleb_many(values: np.ndarray) -> bytes:
    """:func:`uleb` of each of ``values`` (non-negative int64), joined: 7-bit groups as
    the columns of a table, the groups past each value's last left out (a palette of 64k
    values: 60x faster than a call a value)."""
    v = np.asarray(values, dtype=np.int64).astype(np.uint64)
    groups = (v[:, None] >> (7 * np.arange(10, dtype=np.uint64))) & np.uint64(0x7F)
    # the groups up to the highest non-zero one (one for zero)
    count = 10 - np.argmax(groups[:, ::-1] != 0, axis=1)
    count[v == 0] = 1
    keep = np.arange(10) < count[:, None]
    more = np.arange(10) < count[:, None] - 1
    return (groups.astype(np.uint8) | (more * 0x80).astype(np.uint8))[keep].tobytes()


def unpack(data: memoryview, limit: int) -> tuple[np.ndarray, int]:
    """Read a palette of at most ``limit`` values from ``data``; return it and the bytes
    it used. A palette that is too long, runs past ``data`` or leaves the 64-bit range
    raises FormatError."""
    k, pos = read_uleb(data, 0)
    if not 1 <= k <= limit:
        raise FormatError(f"corrupt palette: expected 1..{limit} values, found {k}")
    z, pos = read_uleb(data, pos)
    value = (z >> 1) ^ -(z & 1)
    if value < -(1 << 63):
        raise FormatError("corrupt palette: a value leaves the 64-bit range")
    gaps = _read_gaps(data, pos, k - 1)
    if gaps is not None:  # numpy passes instead of a Python loop a value (the GIL is held)
        g, used = gaps
        if value + int(g.sum(dtype=np.int64)) + k - 1 >= 1 << 63:
            raise FormatError("corrupt palette: a value leaves the 64-bit range")
        out = np.empty(k, dtype=np.int64)
        out[0] = value
        np.cumsum(g + 1, out=out[1:])
        out[1:] += value
        return out, pos + used
    out = np.empty(k, dtype=np.int64)
    out[0] = value
    for i in range(1, k):
        g, pos = read_uleb(data, pos)
        value += g + 1
        if value >= 1 << 63:
            raise FormatError("corrupt palette: a value leaves the 64-bit range")
        out[i] = value
    return out, pos


# Gaps of up to this many LEB128 bytes (42 bits) are read in numpy passes: 65536 of them
# sum within int64. A longer one (a corrupt palette, or values 2^42 apart) takes the loop.
GAP_BYTES = 6


def _read_gaps(data: memoryview, pos: int, n: int) -> tuple[np.ndarray, int] | None:
    """The ``n`` LEB128 gaps from ``pos`` (int64) and the bytes they take, or None where
    they run past ``data`` or one is longer than GAP_BYTES (:func:`unpack`'s loop then
    reads them, with its errors). A palette of 4136 values with multi-byte gaps (a
    float field's quantised voxels at 1e-5 of its range): 1.1 ms by the loop, 0.09 here."""
    buf = np.frombuffer(data[pos : pos + GAP_BYTES * n], dtype=np.uint8)
    if buf.size >= n and not (buf[:n] & 0x80).any():  # every gap one byte (most palettes)
        return buf[:n].astype(np.int64), n
    ends = np.flatnonzero(buf < 0x80)[:n]  # each gap's last byte
    if ends.size < n:
        return None
    starts = np.empty(n, np.int64)
    starts[0] = 0
    starts[1:] = ends[:-1] + 1
    if int((ends - starts).max()) >= GAP_BYTES:
        return None
    used = int(ends[-1]) + 1
    owner = np.zeros(used, np.int64)  # the gap each byte belongs to
    owner[starts[1:]] = 1
    np.cumsum(owner, out=owner)
    shift = 7 * (np.arange(used) - starts[owner])
    return np.add.reduceat((buf[:used] & 0x7F).astype(np.int64) << shift, starts), used


def uleb(v: int) -> bytes:
    out = bytearray()
    while True:
        b = v & 0x7F
        v >>= 7
        if v:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def read_uleb(data: memoryview, pos: int) -> tuple[int, int]:
    v = 0
    shift = 0
    while True:
        if pos >= len(data):
            raise FormatError("corrupt palette: the stream ends inside a number")
        b = data[pos]
        pos += 1
        v |= (b & 0x7F) << shift
        if not b & 0x80:
            return v, pos
        shift += 7
        if shift > 63:
            raise FormatError("corrupt palette: a number longer than 64 bits")


def pack_range(lo: int, hi: int) -> bytes:
    """A value range ``[lo, hi]`` as ``sleb lo`` (zig-zagged ``uleb``), ``uleb span``."""
    return uleb((lo << 1) ^ (lo >> 63)) + uleb(hi - lo)


def read_range(data: memoryview, vmin: int, vmax: int, what: str) -> tuple[int, int, int]:
    """Read :func:`pack_range`'s bytes at the start of ``data``: ``(lo, hi, bytes read)``;
    a range outside ``[vmin, vmax]`` raises FormatError naming ``what``."""
    z, pos = read_uleb(data, 0)
    span, pos = read_uleb(data, pos)
    lo = (z >> 1) ^ -(z & 1)
    if lo < vmin or lo + span > vmax:
        raise FormatError(f"{what}: value range [{lo}, {lo + span}] outside [{vmin}, {vmax}]")
    return lo, lo + span, pos
