"""The float wavelet path's outliers as a sparse field of whole bins, coded row by row.

After the float CDF 9/7 (:mod:`volpack.volume_codec.bounded_cdf97`) a few percent of the
voxels stray past the bound and are moved back by ``r`` whole bins (mostly +-1). The
dense coding of that field through the coefficient coder spends two or three decisions
on every voxel, zero or not, and decoded at a third to a half of the whole brick's time
on the climate fields. Here each row (the voxels along x at one ``z, y``) first says
whether it holds any outlier; only those rows are visited voxel by voxel. Outliers
cluster (a badly fitted ridge spans neighbouring voxels), so each decision is modelled
on the decoded neighbours: the row flag on the rows above and in the slice before, the
voxel flag on the left two, the three above and the one in the slice before, the sign
on the left and upper signs. Layout: ``formats/lossy-1.md`` (outlier kind 2).

The decoder adds the bins to the reconstruction as it reads them (``rec += r * width``
in double precision, as :func:`volpack.volume_codec.bounded_cdf97.add_bins` does).
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, leading_zeros
from ..entropy.common import check_status, encode_with_retry
from ..entropy.rangecoder import (
    RATE,
    STATE_INIT,
    finish_stream,
    get,
    get_raw,
    open_encoder,
    open_stream,
    put,
    put_raw,
)
from ..errors import FormatError

MAX_BITS = 31  # |r| < 2^31, as the encoder keeps it
# Model layout: row flags (4), voxel flags (64), signs (9), magnitude bit lengths (31).
ROW, FLAG, SIGN, MAG = 0, 4, 68, 77
N_MODELS = MAG + MAX_BITS


# The kernels keep the sign states (0, 1 for r > 0, 2 for r < 0) in an array padded by
# zeros (one slice before, a row either side, two voxels before and one after each row),
# so every neighbour is read without a bounds test: voxel (z, y, x) is at [z+1, y+1, x+2].


@kernel(inline=True)
def _row_contexts(s, z, y, nx, ctx):
    """Models of the voxel flags of row ``(z, y)`` from the rows coded before it; the
    two left neighbours are added as the row is coded."""
    for x in range(nx):
        up, prev = s[z + 1, y], s[z, y + 1]
        k = 4 * np.int64(up[x + 2] != 0)
        k += 8 * np.int64((up[x + 1] | up[x + 3]) != 0)
        k += 16 * np.int64(prev[x + 2] != 0) + 32 * np.int64(s[z, y + 2, x + 2] != 0)
        ctx[x] = FLAG + k


@kernel(inline=True)
def _row_model(rows, z, y):
    return ROW + np.int64(rows[z + 1, y]) + 2 * np.int64(rows[z, y + 1])


@kernel(inline=True)
def _padded(shape):
    nz, ny, nx = shape
    s = np.zeros((nz + 1, ny + 2, nx + 3), dtype=np.int8)
    cs = np.empty(3, dtype=np.int64)  # the coder's state for put_raw and get_raw
    rows = np.zeros((nz + 1, ny + 1), dtype=np.uint8)
    ctx = np.empty(nx, dtype=np.int64)
    models = np.full(N_MODELS, STATE_INIT, dtype=np.uint16)
    return s, rows, ctx, models, cs


@kernel
def _encode_kernel(r, out):
    nz, ny, nx = r.shape
    s, rows, ctx, models, cs = _padded(r.shape)
    cap = out.size
    low, rng, pos = open_encoder(out)
    for z in range(nz):
        for y in range(ny):
            any_ = 0
            for x in range(nx):
                if r[z, y, x] != 0:
                    any_ = 1
                    break
            if pos + 16 > cap:
                return -1
            low, rng, pos = put(out, models, _row_model(rows, z, y), any_, low, rng, pos, RATE)
            if any_ == 0:
                continue
            rows[z + 1, y + 1] = 1
            _row_contexts(s, z, y, nx, ctx)
            row = s[z + 1, y + 1]
            seen = 0
            l1 = l2 = 0  # the two left neighbours' states
            for x in range(nx):
                if pos + 32 > cap:
                    return -1
                v = r[z, y, x]
                bit = np.int64(v != 0)
                if not (x == nx - 1 and seen == 0):  # else implied by the row flag
                    k = ctx[x] + np.int64(l1 != 0) + 2 * np.int64(l2 != 0)
                    low, rng, pos = put(out, models, k, bit, low, rng, pos, RATE)
                l2 = l1
                l1 = 0
                if bit == 0:
                    continue
                seen = 1
                neg = np.int64(v < 0)
                k = SIGN + 3 * np.int64(l2) + np.int64(s[z + 1, y, x + 2])
                low, rng, pos = put(out, models, k, neg, low, rng, pos, RATE)
                l1 = 1 + neg
                row[x + 2] = l1
                m = np.uint64(-v if neg else v)
                nb = 64 - np.int64(leading_zeros(m))
                for j in range(1, MAX_BITS):  # the bit length in unary, from 1
                    more = np.int64(nb > j)
                    low, rng, pos = put(out, models, MAG + j, more, low, rng, pos, RATE)
                    if more == 0:
                        break
                if nb > 1:  # the bits below the leading one, at one half (rare)
                    cs[0], cs[1], cs[2] = low, rng, pos
                    put_raw(cs, out, m, nb - 1)
                    low, rng, pos = cs[0], cs[1], cs[2]
    return finish_stream(out, low, pos)


@kernel
def _decode_kernel(data, rec, width):
    """Add the coded bins times ``width`` to ``rec``; 0, or 1 when the stream ran short."""
    nz, ny, nx = rec.shape
    size = data.size
    s, rows, ctx, models, cs = _padded(rec.shape)
    code, rng, pos = open_stream(data)
    for z in range(nz):
        for y in range(ny):
            if pos > size + 4:
                return 1
            k = _row_model(rows, z, y)
            any_, code, rng, pos = get(data, models, k, code, rng, pos, RATE)
            if any_ == 0:
                continue
            rows[z + 1, y + 1] = 1
            row = s[z + 1, y + 1]
            # The rows the contexts read (those of _row_contexts, inline: one pass, and
            # unsigned indices, which numba does not test for a negative wrap-around).
            up, prev, prev_next = s[z + 1, y], s[z, y + 1], s[z, y + 2]
            out = rec[z, y]
            seen = 0
            l1 = l2 = 0
            for x in range(nx):
                ux = np.uint64(x)
                if x == nx - 1 and seen == 0:
                    bit = 1
                else:
                    k = FLAG + 4 * np.int64(up[ux + 2] != 0)
                    k += 8 * np.int64((up[ux + 1] | up[ux + 3]) != 0)
                    k += 16 * np.int64(prev[ux + 2] != 0) + 32 * np.int64(prev_next[ux + 2] != 0)
                    k += np.int64(l1 != 0) + 2 * np.int64(l2 != 0)
                    bit, code, rng, pos = get(data, models, k, code, rng, pos, RATE)
                l2 = l1
                l1 = 0
                if bit == 0:
                    continue
                seen = 1
                k = SIGN + 3 * np.int64(l2) + np.int64(up[ux + 2])
                neg, code, rng, pos = get(data, models, k, code, rng, pos, RATE)
                l1 = 1 + neg
                row[ux + 2] = l1
                nb = 1
                while nb < MAX_BITS:
                    more, code, rng, pos = get(data, models, MAG + nb, code, rng, pos, RATE)
                    if more == 0:
                        break
                    nb += 1
                m = np.int64(1)
                if nb > 1:
                    cs[0], cs[1], cs[2] = code, rng, pos
                    m = np.int64(get_raw(cs, data, nb - 1)) | (m << (nb - 1))
                    code, rng, pos = cs[0], cs[1], cs[2]
                out[ux] += np.float64(-m if neg else m) * width
            if pos > size + 4:
                return 1
    return 0


def encode(r: np.ndarray) -> bytes:
    """Code the 3-D int64 field ``r`` of bins (``|r| < 2^31``, mostly 0)."""
    r = np.ascontiguousarray(r, dtype=np.int64)
    return encode_with_retry(lambda out: _encode_kernel(r, out), r.size, (1, 12))


def add_decoded(data: bytes | memoryview, rec: np.ndarray, width: float) -> None:
    """Add the bins of :func:`encode` times ``width`` to ``rec`` (3-D float64, C order)."""
    if rec.ndim != 3 or rec.dtype != np.float64 or not rec.flags.c_contiguous:
        raise FormatError("bin field: expected a C-contiguous 3-D float64 reconstruction")
    buf = np.frombuffer(bytes(data), dtype=np.uint8)
    if buf.size < 5:
        raise FormatError("bin field: the stream is cut short")
    check_status(_decode_kernel(buf, rec, float(width)), "outlier bin field")
