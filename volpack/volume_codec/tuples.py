"""Tuple palettes: a colour volume stored as its distinct voxel tuples and an index volume.

A scan shown through a colour map, a label map in a colour per label, an RGBA transfer
function: each voxel's channels are a function of one hidden value, so the volume takes
few distinct tuples (a few hundred of 16M RGB colours). Coded channel by channel, each
channel pays for every bend of the map (Colin27 through a colour map: 5.17:1 against
zstd -19's 5.94, which finds the repeated byte triples). Stored instead as the palette
of its ``K`` tuples and the 3-D volume of each voxel's index into it, the index volume is
coded by the brick codec as any scan; in an order that follows the hidden value it *is*
that scan (up to a monotone map the palette ranks of the lossless codec absorb).

The order is chosen by coding a sample of the index volume in each candidate order
(:data:`ORDERS`): the tuples sorted as numbers (channel 0 first: right for a grey map
and a map whose first channel is monotone), by their projection on the first principal
axis of the voxels' colours (a map whose brightness is monotone), along a chain of the
tuples most often next to each other in the volume (:func:`chain_order`: any map of a
smooth value, also jet or turbo, whose colours turn back; labels blended over a scan),
and that chain with each tuple settled between its neighbours (:func:`settled_order`).
Coded in full on session 33's colour volumes (``results/lossless/cpal33/orders.csv``),
the sorted order was the shortest on a grey and a diverging map, the chain on labels in
colours, an RGBA ramp and labels blended over a scan, the settled chain on gamma,
viridis and turbo maps; the sample picks the shortest or one within 3 %.

The encoder keeps the palette where the sample says it codes shorter than the channels
(:func:`plan`). Header ``"channels": {"axis": "last" | "first", "tuples": K}``, the
palette in chunk ``(1, 0)`` (:func:`pack`), the index bricks as chunks ``(0, node)`` of
uint8 (K <= 256) or uint16; ``formats/README.md`` gives the bytes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from ..errors import FormatError
from ..format.deflate import deflate, inflate
from . import interleave as il
from . import palette as pal

MAX_TUPLES = 1 << 16  # an index of 16 bits
# "Clearly fewer than the voxels": at least this many voxels a tuple on average, else
# the channels are noise (a fluorescence stack) and the palette is not tried.
MIN_VOXELS_PER_TUPLE = 8
KEY_BITS = 64  # tuples packed into one uint64 key: 8 channels of 8 bits, 4 of 16, 2 of 32
ORDERS = ("sorted", "principal", "chain", "settled")
SETTLE_ROUNDS, SETTLE_KEEP = 30, 0.2  # settled_order's smoothing
# Pairs of neighbouring voxels the chain order counts at most along each axis (a 7M-voxel
# volume: every second slice; the counts only rank the pairs).
CHAIN_PAIRS = 1 << 22
AXES = ("last", "first")  # the header's channels axis: (z, y, x, c) or (c, z, y, x)


@dataclasses.dataclass
class Plan:
    """What :func:`plan` chose: the tuples in their stored order, the index volume, and
    the estimates the choice was made on (for the log and the tests)."""

    tuples: np.ndarray  # (K, C), the stored order
    index: np.ndarray  # (z, y, x) uint8 or uint16
    order: str
    estimate: int  # estimated bytes with the palette (index bricks + palette chunk)
    channels_estimate: int  # estimated bytes of the channels as today's path stores them


def index_dtype(k: int) -> np.dtype:
    """The index volume's voxel type for a palette of ``k`` tuples."""
    return np.dtype(np.uint8) if k <= 256 else np.dtype("<u2")


def _unsigned(a: np.ndarray, to: type) -> np.ndarray:
    """Native integer voxels of at most 32 bits as unsigned ``to`` in the same order
    (signed ones with their sign bit flipped)."""
    if a.dtype.kind == "i":
        u = a.view(f"u{a.dtype.itemsize}")
        a = u ^ u.dtype.type(1 << (8 * a.dtype.itemsize - 1))
    return a.astype(to)


# Keys of up to this many bits are ranked through a table (16 M entries: 16 MB of flags,
# 32 MB of ranks; RGB of 8 bits), longer ones by a sort.
DENSE_KEY_BITS = 24


def find(series: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The distinct tuples of a ``(c, z, y, x)`` integer series (channel-major, as the
    channels are stored) in sorted order (channel 0 first), ``(K, C)``, and each voxel's
    index into them, ``(z, y, x)``; None where the tuples are wider than 64 bits, more
    than :data:`MAX_TUPLES` or fewer than :data:`MIN_VOXELS_PER_TUPLE` voxels each. The
    keys take 4 bytes a voxel where the tuples fit 32 bits (8 otherwise), the index 2
    where they fit 24 bits (8 otherwise)."""
    series = series.astype(series.dtype.newbyteorder("="), copy=False)
    c, dtype = series.shape[0], series.dtype
    bits = 8 * dtype.itemsize
    if dtype.kind not in "iu" or c * bits > KEY_BITS or c < 2:
        return None
    n = series[0].size
    limit = min(MAX_TUPLES, n // MIN_VOXELS_PER_TUPLE)
    kdt = np.uint32 if c * bits <= 32 else np.uint64

    def keys_of(part: np.ndarray) -> np.ndarray:
        k = np.zeros(part.shape[1:], kdt)
        for ch in range(c):
            k <<= kdt(bits)
            k |= _unsigned(part[ch], kdt)
        return k

    step = max(1, series.shape[1] // 16)  # a few slices first: noise is refused cheaply
    if pal.sorted_unique(keys_of(series[:, ::step]).reshape(-1)).size > limit:
        return None
    keys = keys_of(series)
    if c * bits <= DENSE_KEY_BITS:
        seen = np.zeros(1 << (c * bits), bool)
        seen[keys.reshape(-1)] = True
        uniq = np.flatnonzero(seen).astype(kdt)
        if uniq.size > limit:
            return None
        rank = np.zeros(seen.size, np.uint16)
        rank[uniq] = np.arange(uniq.size)
        index = rank[keys]
    else:
        uniq = pal.sorted_unique(keys.reshape(-1))
        if uniq.size > limit:
            return None
        index = np.searchsorted(uniq, keys)
    mask = np.uint64((1 << bits) - 1)
    shift = (1 << (bits - 1)) if dtype.kind == "i" else 0
    tuples = np.empty((uniq.size, c), dtype)
    for ch in range(c):
        u = (uniq.astype(np.uint64) >> np.uint64(bits * (c - 1 - ch))) & mask
        tuples[:, ch] = (u.astype(np.int64) - shift).astype(dtype)
    return tuples, index


def principal_order(tuples: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """The tuples' order along the first principal axis of the voxels' colours (each
    tuple weighted by its voxels), ties by the sorted order."""
    x = tuples.astype(np.float64)
    w = counts.astype(np.float64) / max(1.0, float(counts.sum()))
    centred = x - w @ x
    cov = (centred * w[:, None]).T @ centred
    axis = np.linalg.eigh(cov)[1][:, -1]
    axis = axis if axis[np.argmax(np.abs(axis))] > 0 else -axis  # a fixed sign
    return np.lexsort((np.arange(len(x)), np.round(centred @ axis, 9)))


def pair_counts(index: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """How often tuples ``a < b`` are next to each other along z, y or x in ``index``
    (``(z, y, x)``, sorted-order indices; at most about :data:`CHAIN_PAIRS` pairs an
    axis, from evenly spread slices): ``(a, b, count)``."""
    step = -(-index.size // CHAIN_PAIRS)
    sub = index[::step]
    pairs = (
        (index[:-1:step], index[1::step]),  # along z: every step-th pair of slices
        (sub[:, :-1], sub[:, 1:]),
        (sub[:, :, :-1], sub[:, :, 1:]),
    )
    codes = []
    for lo, hi in pairs:
        a, b = np.minimum(lo, hi).reshape(-1), np.maximum(lo, hi).reshape(-1)
        keep = a != b
        codes.append(a[keep].astype(np.int64) * k + b[keep])
    code = np.concatenate(codes)
    if k * k <= 1 << 24:
        counts = np.bincount(code, minlength=k * k)
        code = np.flatnonzero(counts)
        counts = counts[code]
    else:
        code, counts = np.unique(code, return_counts=True)
    return code // k, code % k, counts


def chain_order(tuples: np.ndarray, pairs: tuple, counts: np.ndarray) -> np.ndarray:
    """The tuples along chains of neighbours: the pairs of tuples met side by side in the
    volume, most often first, join into paths (each tuple at most two neighbours, no
    loop: the greedy matching of the travelling salesman); the paths are then laid
    end to end in their order along the first principal axis. A colour map of a smooth
    scan becomes the scan's values again, whatever the map's turns in colour space."""
    k = len(tuples)
    a, b, w = pairs
    by = np.lexsort((b, a, -w))  # heaviest first, ties in a fixed order
    a, b = a[by].tolist(), b[by].tolist()
    root = list(range(k))

    def find_root(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    degree = [0] * k
    nbrs: list[list[int]] = [[] for _ in range(k)]
    joined = 0
    for i, j in zip(a, b):
        if degree[i] < 2 and degree[j] < 2:
            ri, rj = find_root(i), find_root(j)
            if ri != rj:
                root[ri] = rj
                degree[i] += 1
                degree[j] += 1
                nbrs[i].append(j)
                nbrs[j].append(i)
                joined += 1
                if joined == k - 1:
                    break
    rank = np.empty(k, np.int64)
    rank[principal_order(tuples, counts)] = np.arange(k)
    seen = [False] * k
    paths = []
    for start in range(k):  # walk each path from its lower end
        if seen[start] or degree[start] == 2:
            continue
        path, prev, cur = [], -1, start
        while cur != -1:
            seen[cur] = True
            path.append(cur)
            nxt = [n for n in nbrs[cur] if n != prev]
            prev, cur = cur, (nxt[0] if nxt else -1)
        if rank[path[-1]] < rank[path[0]]:
            path.reverse()
        paths.append(path)
    paths.sort(key=lambda p: float(np.mean(rank[p])))
    return np.array([t for p in paths for t in p], dtype=np.int64)


def settled_order(perm: np.ndarray, pairs: tuple) -> np.ndarray:
    """``perm`` with each tuple moved toward its neighbours: SETTLE_ROUNDS times, each
    tuple's position becomes SETTLE_KEEP of its own plus the rest of the mean position
    of the tuples next to it in the volume (weighted by how often), and the positions
    are ranked again. The greedy chain can leave rare tuples (a grey level of a few voxels)
    at its ends or where a heavier pair took their place; here they settle between
    their neighbours (measured: the index of MNI152 through turbo 6.5 % shorter, within
    2 % of the grey scan itself). Tuples of two mixed structures (labels blended over a
    scan) are pulled across both, so the chain stays a candidate of its own."""
    a, b, w = pairs
    k = len(perm)
    w = w.astype(np.float64)
    degree = np.bincount(a, w, k) + np.bincount(b, w, k)
    x = np.empty(k)
    x[perm] = np.arange(k)
    for _ in range(SETTLE_ROUNDS):
        pull = np.bincount(a, w * x[b], k) + np.bincount(b, w * x[a], k)
        mean = np.where(degree > 0, pull / np.maximum(degree, 1e-300), x)
        x = SETTLE_KEEP * x + (1 - SETTLE_KEEP) * mean
        x[np.lexsort((np.arange(k), x))] = np.arange(k)  # ranks again: no collapse
    return np.lexsort((np.arange(k), x))


def candidate_orders(tuples: np.ndarray, index: np.ndarray) -> dict[str, np.ndarray]:
    """Each order of :data:`ORDERS` as a permutation of the sorted tuples (distinct
    permutations only: a palette of one or two tuples has one order)."""
    counts = np.bincount(index.reshape(-1), minlength=len(tuples))
    pairs = pair_counts(index, len(tuples))
    out: dict[str, np.ndarray] = {}
    chain = None  # (the settled order starts from it, kept or not)
    for name in ORDERS:
        if name == "sorted":
            perm = np.arange(len(tuples))
        elif name == "principal":
            perm = principal_order(tuples, counts)
        elif name == "chain":
            perm = chain = chain_order(tuples, pairs, counts)
        else:
            perm = settled_order(chain, pairs)
        if not any(np.array_equal(perm, p) or np.array_equal(perm[::-1], p) for p in out.values()):
            out[name] = perm
    return out


def reorder(index: np.ndarray, perm: np.ndarray) -> np.ndarray:
    """The index volume with the tuples in order ``perm`` (``perm[i]``: the sorted tuple
    stored at ``i``), as the stored voxel type."""
    rank = np.empty(len(perm), index_dtype(len(perm)))
    rank[perm] = np.arange(len(perm))
    return rank[index]


def plan(
    series: np.ndarray, size_of: Callable[[np.ndarray], int], force: bool = False
) -> tuple[Plan | None, bool | None]:
    """Whether a ``(c, z, y, x)`` integer series (the channels as stored) codes shorter
    as a tuple palette, and in which order; ``size_of(volume)`` is the bytes of a 3-D
    volume's bricks as the encoder codes them. Estimated on il.sample's cut (the
    central 48^3 voxels of every channel) scaled to the volume: the channels coded one
    by one and interleaved (the shorter is what the encoder keeps without a palette),
    the index in each candidate order, the palette's own bytes added. Returns the plan
    (None where :func:`find` finds no palette or its estimate is not below the
    channels'; with ``force`` wherever there is a palette) and whether the sample codes
    shorter interleaved (il.pays' answer, None where not sampled)."""
    found = find(series)
    if found is None:
        return None, None
    tuples, index = found
    part = il.sample(series)
    box = tuple(
        slice((n - m) // 2, (n - m) // 2 + m) for n, m in zip(series.shape[1:], part.shape[1:])
    )
    scale = index.size / max(1, part[0].size)
    apart = sum(size_of(frame) for frame in part)
    folded = size_of(il.fold(part))
    channels = min(apart, folded) * scale
    best = None
    for name, perm in candidate_orders(tuples, index).items():
        stored = reorder(index, perm)
        est = size_of(np.ascontiguousarray(stored[box])) * scale + len(pack(tuples[perm]))
        if best is None or est < best[0]:
            best = (est, name, perm, stored)
    est, name, perm, stored = best
    if est >= channels and not force:
        return None, folded < apart
    return Plan(tuples[perm], stored, name, int(est), int(channels)), folded < apart


def _udtype(dtype: np.dtype) -> np.dtype:
    """The little-endian unsigned type of ``dtype``'s width."""
    return np.dtype(f"<u{np.dtype(dtype).itemsize}")


def pack(tuples: np.ndarray) -> bytes:
    """The palette chunk: the ``(K, C)`` tuples channel by channel, each channel's ``K``
    values as differences from the previous (the first from 0) modulo 2^bits, unsigned
    little-endian, in one zstd frame."""
    cols = np.ascontiguousarray(tuples.T).view(f"u{tuples.dtype.itemsize}")
    diff = cols.copy()
    diff[:, 1:] = cols[:, 1:] - cols[:, :-1]  # unsigned: wraps modulo 2^bits
    return deflate(diff.astype(_udtype(tuples.dtype)).tobytes())


def unpack(payload: bytes | memoryview, k: int, c: int, dtype: np.dtype) -> np.ndarray:
    """The ``(k, c)`` tuples of a palette chunk (:func:`pack`) as native ``dtype``; a
    chunk that is not one zstd frame of exactly ``k * c`` values raises FormatError."""
    dtype = np.dtype(dtype).newbyteorder("=")
    raw = inflate(payload, k * c * dtype.itemsize, "tuple palette", exact=True)
    diff = np.frombuffer(raw, _udtype(dtype)).reshape(c, k)
    cols = np.cumsum(diff, axis=1, dtype=diff.dtype.newbyteorder("="))  # modulo 2^bits
    return np.ascontiguousarray(cols.T).view(dtype)


def lookup(tuples: np.ndarray, index: np.ndarray, channel: int | None, axis: str) -> np.ndarray:
    """Voxels of the index volume ``index`` (or of one ``channel``): ``(z, y, x, c)``
    for axis ``last``, ``(c, z, y, x)`` for ``first``. An index past the palette raises
    FormatError."""
    if index.size and int(index.max()) >= len(tuples):
        raise FormatError(
            f"corrupt tuple palette index: {int(index.max())} in a palette of {len(tuples)} tuples"
        )
    if channel is not None:
        return tuples[:, channel][index]
    if axis == "last":
        return tuples[index]
    return np.stack([tuples[:, ch][index] for ch in range(tuples.shape[1])])


def check_header(spec: object, shape: tuple[int, ...], dtype: str, layout: bool) -> None:
    """Check a volume header's ``"channels"`` object: ``{"axis": "last" | "first",
    "tuples": K}`` with ``1 <= K <= MAX_TUPLES``, a 4-D shape of integer voxels whose
    tuples (the channel axis's voxels) fit 64 bits, and no ``layout``; else FormatError.
    The 64 bits bound the palette chunk (at most 512 KiB) before it is read."""
    ok = isinstance(spec, dict) and set(spec) == {"axis", "tuples"} and spec["axis"] in AXES
    k = spec.get("tuples") if isinstance(spec, dict) else None
    ok = ok and isinstance(k, int) and not isinstance(k, bool) and 1 <= k <= MAX_TUPLES
    dt = np.dtype(dtype)
    if ok and len(shape) == 4 and dt.kind in "iu" and not layout:
        c = shape[-1] if spec["axis"] == "last" else shape[0]
        if c * 8 * dt.itemsize <= KEY_BITS:
            return
    raise FormatError(
        f"expected channels {{'axis': 'last' or 'first', 'tuples': 1..{MAX_TUPLES}}} of a 4-D "
        f"integer volume of tuples up to 64 bits without a layout, found {spec!r:.80} of "
        f"shape {list(shape)}, dtype {dtype!r:.20}" + (", with a layout" if layout else "")
    )
