"""The quantised voxels predicted by a long least-squares predictor, the residual coded
by the lossless codec (the bounded codec's flag ``residuals`` alone; formats/lossy-1.md
step 20).

On a field sampled finer than its content (a spectral simulation's velocity, de-aliased
to 2/3 of the grid's wavenumbers), a voxel is predictable from far along each axis: a
linear predictor over the 62 causal neighbours within two voxels and the next ``K`` back
along each axis, fitted per brick by least squares on the quantised voxels (which the
decoder has: closed-loop prediction on the decoded values), leaves a residual 2-3x
smaller than 16 neighbours do on the Taylor-Green velocity (scripts/
lossy17_predictor_entropy.py). Voxels whose long neighbourhood leaves the brick take
the fitted predictor over the 62 near neighbours, and those nearer the faces a Lorenzo
predictor of the neighbours there. Weights are fixed point (2^-16), sums in int64:
encoder and decoder compute the same integers on any machine. The residual volume,
shifted to start at 0, is coded by the lossless codec (its predictive tools give it
the local activity contexts).
"""

from __future__ import annotations

import struct

import numpy as np

from .._jit import kernel
from ..errors import FormatError

FB = 16  # fixed-point bits of the weights
W_LIMIT = 1 << 20  # |weight| < 16
K_TRIED = (4, 8, 12)  # axis reaches the encoder tries
K_MAX = 16
_DTYPES = (np.uint8, np.uint16, np.uint32)
_HEAD = struct.Struct("<BBq")  # K, residual dtype code, residual offset


def near_offsets() -> tuple:
    """Every causal (dz, dy, dx) step back within two voxels (62)."""
    out = []
    for dz in range(3):
        for dy in range(-2, 3):
            for dx in range(-2, 3):
                if dz == 0 and (dy < 0 or (dy == 0 and dx <= 0)):
                    continue
                out.append((dz, dy, dx))
    return tuple(out)


def long_offsets(k: int) -> tuple:
    """:func:`near_offsets` and the steps 3..k back along each axis."""
    extra = [(0, 0, d) for d in range(3, k + 1)] + [(0, d, 0) for d in range(3, k + 1)]
    return near_offsets() + tuple(extra + [(d, 0, 0) for d in range(3, k + 1)])


def _box(offs) -> np.ndarray:
    """(back z, back y, ahead y, back x, ahead x): where every neighbour exists."""
    o = np.array(offs)
    return np.array(
        [o[:, 0].max(), o[:, 1].max(), max(0, -o[:, 1].min()), o[:, 2].max(),
         max(0, -o[:, 2].min())], dtype=np.int64,
    )  # fmt: skip


def _flat(offs, shape) -> np.ndarray:
    _, ny, nx = shape
    return np.array([dz * ny * nx + dy * nx + dx for dz, dy, dx in offs], dtype=np.int64)


@kernel(inline=True)
def _inside(z, y, x, ny, nx, b):
    return z >= b[0] and y >= b[1] and y + b[2] < ny and x >= b[3] and x + b[4] < nx


@kernel(inline=True)
def _lorenzo(q, i, z, y, x, sy, sz):
    """The Lorenzo predictor of the neighbours that exist (0 at the first voxel)."""
    p = np.int64(0)
    if z > 0 and y > 0 and x > 0:
        p = (q[i - 1] + q[i - sy] + q[i - sz] - q[i - sy - 1] - q[i - sz - 1] - q[i - sz - sy]
             + q[i - sz - sy - 1])  # fmt: skip
    elif y > 0 and x > 0:
        p = q[i - 1] + q[i - sy] - q[i - sy - 1]
    elif z > 0 and x > 0:
        p = q[i - 1] + q[i - sz] - q[i - sz - 1]
    elif z > 0 and y > 0:
        p = q[i - sy] + q[i - sz] - q[i - sz - sy]
    elif x > 0:
        p = q[i - 1]
    elif y > 0:
        p = q[i - sy]
    elif z > 0:
        p = q[i - sz]
    return p


@kernel
def _walk(q, r, o1, w1, b1, o2, w2, b2, nz, ny, nx, decode, qmax):
    """Residuals ``r = q - prediction`` (encode) or ``q = r + prediction`` (decode) in C
    order; returns the first voxel decoded outside ``[0, qmax]`` or -1."""
    sy = nx
    sz = ny * nx
    half = np.int64(1) << (FB - 1)
    i = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if _inside(z, y, x, ny, nx, b1):
                    acc = np.int64(0)
                    for k in range(o1.size):
                        acc += w1[k] * q[i - o1[k]]
                    p = (acc + half) >> FB
                elif _inside(z, y, x, ny, nx, b2):
                    acc = np.int64(0)
                    for k in range(o2.size):
                        acc += w2[k] * q[i - o2[k]]
                    p = (acc + half) >> FB
                else:
                    p = _lorenzo(q, i, z, y, x, sy, sz)
                if decode:
                    v = r[i] + p
                    if v < 0 or v > qmax:
                        return i
                    q[i] = v
                else:
                    r[i] = q[i] - p
                i += 1
    return -1


def _fit(q: np.ndarray, offs) -> np.ndarray:
    """Fixed-point least-squares weights of ``offs`` over the voxels where all exist,
    every other row and column of them (normal equations summed slab by slab; a
    quarter of the work, the same bytes within 0.1 % on the Taylor-Green fields); zeros
    where too few voxels."""
    nz, ny, nx = q.shape
    b = _box(offs)
    z0, y0, y1, x0, x1 = int(b[0]), int(b[1]), ny - int(b[2]), int(b[3]), nx - int(b[4])
    n = len(offs)
    if nz - z0 <= 0 or y1 - y0 <= 0 or x1 - x0 <= 0 or (nz - z0) * (y1 - y0) * (x1 - x0) < 4 * n:
        return np.zeros(n, np.int64)
    f = q.astype(np.float64)
    ata = np.zeros((n, n))
    aty = np.zeros(n)
    for z in range(z0, nz):
        a = np.stack(
            [f[z - dz, y0 - dy:y1 - dy:2, x0 - dx:x1 - dx:2].ravel() for dz, dy, dx in offs],
            axis=1,
        )
        t = f[z, y0:y1:2, x0:x1:2].ravel()
        ata += a.T @ a
        aty += a.T @ t
    try:
        w = np.linalg.solve(ata + 1e-9 * np.trace(ata) / n * np.eye(n), aty)
    except np.linalg.LinAlgError:
        return np.zeros(n, np.int64)
    return np.clip(np.rint(w * (1 << FB)), -W_LIMIT, W_LIMIT).astype(np.int64)


def residuals(q: np.ndarray, k: int, w2: np.ndarray | None = None):
    """(residuals (int64, the brick's shape), long weights, near weights) of reach k
    (the near weights fitted unless given)."""
    q = np.ascontiguousarray(q, dtype=np.int64)
    o1, o2 = long_offsets(k), near_offsets()
    w1 = _fit(q, o1)
    w2 = _fit(q, o2) if w2 is None else w2
    r = np.empty_like(q)
    nz, ny, nx = q.shape
    _walk(q.reshape(-1), r.reshape(-1), _flat(o1, q.shape), w1, _box(o1), _flat(o2, q.shape),
          w2, _box(o2), nz, ny, nx, False, np.int64(0))  # fmt: skip
    return r, w1, w2


def estimate_bits(r: np.ndarray) -> float:
    """Zeroth-order entropy of the residuals, bits in all (the encoder's choice of the
    reach and its gate; the lossless codec's activity contexts code 0-15 % below it)."""
    _, n = np.unique(r, return_counts=True)
    p = n / r.size
    return float(-(n * np.log2(p)).sum())


def encode(fitted, codec) -> bytes | None:
    """Code :func:`residuals`' ``(r, w1, w2)`` (its reach from the weights' count), the
    residual by ``codec`` (a lossless brick codec); ``None`` where the residuals span
    more than 32 bits."""
    r, w1, w2 = fitted
    k = (len(w1) - len(w2)) // 3 + 2
    lo = int(r.min())
    span = int(r.max()) - lo
    code = next((c for c, d in enumerate(_DTYPES) if span <= np.iinfo(d).max), None)
    if code is None:
        return None
    body = codec.encode((r - lo).astype(_DTYPES[code]))
    head = _HEAD.pack(k, code, lo) + w1.astype("<i4").tobytes() + w2.astype("<i4").tobytes()
    return head + body


def decode(data, shape: tuple[int, ...], qdtype: np.dtype, codec) -> np.ndarray:
    """Decode :func:`encode`'s bytes into the quantised voxels (``qdtype``)."""
    buf = bytes(data)
    if len(shape) != 3 or len(buf) < _HEAD.size:
        raise FormatError("bounded long-fit payload: too short or not a 3-D brick")
    k, code, lo = _HEAD.unpack_from(buf)
    if not 2 <= k <= K_MAX or code >= len(_DTYPES):
        raise FormatError(f"bounded long-fit payload: reach {k} or residual type {code} unknown")
    o1, o2 = long_offsets(k), near_offsets()
    pos = _HEAD.size + 4 * (len(o1) + len(o2))
    if len(buf) <= pos:
        raise FormatError("bounded long-fit payload: no residuals after the weights")
    w = np.frombuffer(buf[_HEAD.size:pos], "<i4").astype(np.int64)
    w1, w2 = w[: len(o1)], w[len(o1):]
    if np.abs(w).max(initial=0) > W_LIMIT:
        raise FormatError("bounded long-fit payload: a weight out of range")
    res = codec.decode(buf[pos:], tuple(shape), np.dtype(_DTYPES[code]))
    r = res.astype(np.int64).reshape(-1) + lo
    q = np.empty(r.size, np.int64)
    nz, ny, nx = shape
    qmax = np.int64(np.iinfo(np.dtype(qdtype)).max)
    bad = _walk(q, r, _flat(o1, shape), w1, _box(o1), _flat(o2, shape), w2, _box(o2),
                nz, ny, nx, True, qmax)  # fmt: skip
    if bad >= 0:
        raise FormatError(f"bounded long-fit payload: voxel {bad} decodes out of range")
    return q.reshape(shape).astype(qdtype)
