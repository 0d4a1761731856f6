"""Label maps coded as copies of a neighbour: the lossless tool for segmentations.

In a label map almost every voxel repeats a neighbour, and which neighbour it repeats
follows from which neighbours agree with each other. Voxels are visited in C order and
work on palette ranks (:mod:`.palette`). For each voxel, the distinct labels
among its causal neighbours W, N, U, NE, NW (in that order; a missing neighbour is
skipped) are candidates; one adaptive binary decision per candidate says "it is this
one", in a context made of the candidate's position and the equalities among W, N, U,
NW and NE (which tell an edge from a flat region). A voxel that is none of them (a new
label arriving) has its rank coded bit by bit, most significant first, on a binary tree
of adaptive probabilities. A flat region costs about a thousandth of a bit a voxel.

The byte layout is in ``formats/lossless-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..entropy.common import check_status, encode_with_retry, stream_bytes
from ..entropy.rangecoder import (
    PROB_BITS,
    RATE,
    STATE_INIT,
    adapted,
    end_status,
    finish_stream,
    open_encoder,
    open_stream,
)
from ..entropy.rangecoder import get as _get
from ..entropy.rangecoder import pull as _pull
from ..entropy.rangecoder import put as _put
from .predict import bitlen

NCAND = 5
N_PATTERN = 1 << 7
M_TREE = NCAND * N_PATTERN  # first model of the rank tree
FLAT = N_PATTERN - 1  # the pattern where W, N, U, NE and NW all agree (and x, y > 0)


@kernel(inline=True)
def _candidates(v, i, x, y, z, ny, nx, cand):
    """Fill ``cand`` with the distinct neighbour labels (W, N, U, NE, NW order); return
    their count and the context pattern of the neighbours' equalities."""
    sy = nx
    sz = ny * nx
    w = v[i - 1] if x > 0 else -1
    n = v[i - sy] if y > 0 else -1
    u = v[i - sz] if z > 0 else -1
    ne = v[i - sy + 1] if y > 0 and x + 1 < nx else -1
    nw = v[i - sy - 1] if y > 0 and x > 0 else -1
    pattern = (
        np.int64(w == n)
        | (np.int64(w == u) << 1)
        | (np.int64(n == u) << 2)
        | (np.int64(n == ne) << 3)
        | (np.int64(w == nw) << 4)
        | (np.int64(n == nw) << 5)
        | (np.int64(x > 0 and y > 0) << 6)
    )
    k = 0
    for c in (w, n, u, ne, nw):
        if c < 0:
            continue
        dup = False
        for j in range(k):
            if cand[j] == c:
                dup = True
        if not dup:
            cand[k] = c
            k += 1
    return k, pattern


@kernel(inline=True)
def _flat(v, i, x, y, z, nx, sz):
    """Whether voxel ``i`` = (z, y, x) is inside the brick and its W, N, U, NE and NW
    neighbours all agree: then the distinct candidates are W alone, in pattern FLAT."""
    if not (x > 0 and y > 0 and z > 0 and x + 1 < nx):
        return False
    w = v[np.uint64(i - 1)]  # (unsigned: see the note in predict.py)
    return (
        v[np.uint64(i - nx)] == w
        and v[np.uint64(i - sz)] == w
        and v[np.uint64(i - nx + 1)] == w
        and v[np.uint64(i - nx - 1)] == w
    )


def _workspace(nbits: int) -> tuple[np.ndarray, np.ndarray]:
    """Fresh models and a candidate list (the kernels run without numba's allocator)."""
    return (
        np.full(M_TREE + (2 << nbits), STATE_INIT, dtype=np.uint16),
        np.zeros(NCAND, dtype=np.int64),
    )


@kernel(nrt=False)
def _encode_kernel(v, shape, nbits, out, state, cand):
    nz, ny, nx = shape[0], shape[1], shape[2]
    cap = out.size
    low, rng, pos = open_encoder(out)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if pos + 16 + nbits > cap:
                    return -1
                k, pattern = _candidates(v, i, x, y, z, ny, nx, cand)
                val = v[i]
                found = False
                for j in range(k):
                    bit = np.int64(cand[j] == val)
                    m = j * N_PATTERN + pattern
                    low, rng, pos = _put(out, state, m, bit, low, rng, pos, RATE)
                    if bit:
                        found = True
                        break
                if not found:
                    node = 1
                    for b in range(nbits - 1, -1, -1):
                        bit = (val >> b) & 1
                        low, rng, pos = _put(out, state, M_TREE + node, bit, low, rng, pos, RATE)
                        node = 2 * node + bit
                i += 1
    return finish_stream(out, low, pos)


@kernel(nrt=False)
def _decode_kernel(data, shape, nbits, kmax, v, state, cand):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible label, 3 when
    it does not end where its length says."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    size = data.size
    code, rng, pos = open_stream(data)
    for z in range(nz):
        for y in range(ny):
            i0 = z * sz + y * nx
            x = 0
            while x < nx:
                if pos > size + 4:
                    return 1
                i = i0 + x
                if _flat(v, i, x, y, z, nx, sz):
                    # A run through a flat region (most voxels): one decision a voxel
                    # in model FLAT, which stays in a register until the run ends.
                    w = v[i - 1]
                    st = np.int64(state[FLAT])
                    while True:
                        p = st >> 4
                        u = st & 15
                        bound = (rng >> PROB_BITS) * p
                        if code < bound:  # not W: rare in a run, so a branch
                            rng = bound
                            st = adapted(p, u, 0, RATE)
                            code, rng, pos = _pull(data, code, rng, pos)
                            bit = 0
                            break
                        code -= bound
                        rng -= bound
                        st = adapted(p, u, -1, RATE)
                        code, rng, pos = _pull(data, code, rng, pos)
                        bit = 1
                        v[np.uint64(i)] = w
                        x += 1
                        i += 1
                        if pos > size + 4 or not _flat(v, i, x, y, z, nx, sz):
                            break
                    state[FLAT] = st
                    if bit == 1:
                        continue  # the voxel at x is not flat (or the stream ran short)
                    val = np.int64(-1)  # W, the only candidate, was refused
                else:
                    k, pattern = _candidates(v, i, x, y, z, ny, nx, cand)
                    val = np.int64(-1)
                    for j in range(k):
                        m = j * N_PATTERN + pattern
                        bit, code, rng, pos = _get(data, state, m, code, rng, pos, RATE)
                        if bit:
                            val = cand[j]
                            break
                if val < 0:
                    node = 1
                    for _ in range(nbits):
                        bit, code, rng, pos = _get(data, state, M_TREE + node, code, rng, pos, RATE)
                        node = 2 * node + bit
                    val = node - (np.int64(1) << nbits)
                    if val > kmax:
                        return 2
                v[i] = val
                x += 1
    return end_status(data, code, pos)


def encode(ranks: np.ndarray, k: int) -> bytes:
    """Code a 3-D array of ranks in ``0..k-1``."""
    v = np.ascontiguousarray(ranks, dtype=np.int64)
    nbits = int(bitlen(max(k - 1, 1)))
    shape = np.array(v.shape, dtype=np.int64)
    return encode_with_retry(
        lambda out: _encode_kernel(v.reshape(-1), shape, np.int64(nbits), out, *_workspace(nbits)),
        v.size,
        (1, 4),
        64 * nbits + 1024,
        coder="label",
    )


def decode(
    data: bytes | memoryview, shape: tuple[int, int, int], k: int, palette=None
) -> np.ndarray:
    """Decode :func:`encode`'s bytes into ranks of ``shape`` (uint8 for up to 256 labels,
    uint16 for up to 65,536, else int64: the narrower, the less memory the decoder goes
    through), or into ``palette[rank]`` (in the palette's dtype) when ``palette`` (``k``
    values) is given."""
    buf = stream_bytes(data, "label")
    nbits = int(bitlen(max(k - 1, 1)))
    dtype = np.uint8 if k <= 1 << 8 else np.uint16 if k <= 1 << 16 else np.int64
    v = np.empty(int(np.prod(shape)), dtype=dtype)
    shp = np.array(shape, dtype=np.int64)
    status = _decode_kernel(buf, shp, np.int64(nbits), np.int64(k - 1), v, *_workspace(nbits))
    check_status(status, "label")
    if palette is None:
        return v.reshape(shape)
    out = np.empty(v.size, dtype=palette.dtype)
    _lookup(v, np.ascontiguousarray(palette), out)
    return out.reshape(shape)


@kernel(nrt=False)
def _lookup(ranks, palette, out):
    """``out = palette[ranks]`` in one pass (numpy's fancy index first widens the ranks
    to int64: a pass and a volume of int64 more). The ranks are in range."""
    for i in range(ranks.size):
        out[np.uint64(i)] = palette[np.uint64(ranks[np.uint64(i)])]
