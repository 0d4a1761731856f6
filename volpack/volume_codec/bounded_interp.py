"""The bounded codec's interpolation path: each level's voxels predicted from the coarser
level, the residual quantised to whole bins (``formats/lossy-1.md``, steps 14-18).

Multilevel interpolation (the predictor of SZ3's interpolation mode, written here from
its description): the voxels on a grid of stride ``2s`` are known; the level of stride
``s`` fills in the rest one axis at a time, each new voxel interpolated along that axis
from the known ones at ``+-s`` and ``+-3s`` (cubic, or linear), from the decoded values,
so the decoder predicts exactly as the encoder did. The residual is rounded to bins of
width at most ``2E``: every voxel is within ``E`` by construction. On noisy and thin
fields (an fMRI z-map, monthly maps stacked in time) this codes shorter than wavelets:
a wavelet's quantisation error spreads over neighbours, here it stays put.

The bins are coded with the static rANS coder (:mod:`volpack.entropy.rans`): one lookup
per voxel instead of the adaptive binary coder's several decisions. Contexts: how large
the two voxels it was interpolated from had their bins (the bins cluster where the field
is rough) and the bin coded just before it.

The encoder's choices, made per brick by the estimated coded size and stored: which
axis is interpolated in which order (the pass of the last axis covers half the voxels,
so the smoothest axis goes last), cubic or linear (linear wins on noise), and a finer
step on the coarse levels (their errors are propagated to every finer level).
"""

from __future__ import annotations

import struct

import numpy as np

from .._jit import kernel, leading_zeros
from ..entropy import rans
from ..errors import FormatError
from ..format.deflate import deflate, inflate
from ..format.sections import put_section, take_section

MAX_BIN = 2.0**30  # larger bins (or no finite residual): bin 0, left to the corrections
DIRECT = 32  # zigzagged bins below this are symbols themselves
N_SYM = DIRECT + 2 * (31 - 6) + 2  # bit lengths 6..31 of larger ones, two symbols each
N_ACT = 6  # classes of the interpolating voxels' bins
N_PREV = 3  # classes of the previous bin: 0, 1, more
N_CTX = N_ACT * N_PREV
KINDS = (1, 0, 2, 3)  # cubic, linear, Lorenzo 3-D, Lorenzo 2-D
PERMS = ((0, 1, 2), (1, 0, 2), (2, 1, 0), (0, 2, 1))
HEADER = struct.Struct("<3BB")  # axis order, kind
# What the encoder tries: (kind, axis orders). Lorenzo in 3-D hardly depends on the
# order; in 2-D the order's first axis is the one left out.
TRIED = ((1, PERMS), (0, PERMS), (2, PERMS[:1]), (3, PERMS[:3]))


@kernel(inline=True)
def _predict(rec, z, y, x, axis, s, n, cubic):
    """Voxel (z, y, x) interpolated along ``axis`` from the known ones at +-s, +-3s."""
    i = z if axis == 0 else (y if axis == 1 else x)
    dz = s if axis == 0 else 0
    dy = s if axis == 1 else 0
    dx = s if axis == 2 else 0
    b = rec[z - dz, y - dy, x - dx]
    if i + s >= n:  # no neighbour after: the one before
        return b
    c = rec[z + dz, y + dy, x + dx]
    if cubic == 0:
        return (b + c) * 0.5
    lo = i - 3 * s >= 0
    hi = i + 3 * s < n
    if lo and hi:
        a = rec[z - 3 * dz, y - 3 * dy, x - 3 * dx]
        d = rec[z + 3 * dz, y + 3 * dy, x + 3 * dx]
        return (9.0 * (b + c) - (a + d)) * 0.0625
    if hi:  # the quadratic through -s, s, 3s
        d = rec[z + 3 * dz, y + 3 * dy, x + 3 * dx]
        return (3.0 * b + 6.0 * c - d) * 0.125
    if lo:  # the quadratic through -3s, -s, s
        a = rec[z - 3 * dz, y - 3 * dy, x - 3 * dx]
        return (6.0 * b + 3.0 * c - a) * 0.125
    return (b + c) * 0.5


def _act_contexts() -> np.ndarray:
    """Context base of each sum of the two neighbours' bin magnitudes (0..254): its bit
    length, capped at ``N_ACT - 1``, times ``N_PREV``."""
    a = np.arange(255)
    bits = np.where(a > 0, np.floor(np.log2(np.maximum(a, 1))) + 1, 0)
    return (np.minimum(bits, N_ACT - 1) * N_PREV).astype(np.int64)


ACT_CONTEXT = _act_contexts()


@kernel(inline=True)
def _put_bits(raw, bitpos, v, n):
    """Append the ``n`` low bits of ``v`` to ``raw`` (zeroed), least significant first."""
    for j in range(n):
        if (v >> j) & 1:
            raw[(bitpos + j) >> 3] |= np.uint8(1 << ((bitpos + j) & 7))
    return bitpos + n


@kernel(inline=True)
def _get_bits(raw, bitpos, n):
    """``n`` bits of ``raw`` from ``bitpos`` (zeros past its end: checked at the end)."""
    v = np.int64(0)
    for j in range(n):
        i = (bitpos + j) >> 3
        if i < raw.size:
            v |= np.int64((raw[i] >> ((bitpos + j) & 7)) & 1) << j
    return v


@kernel(inline=True)
def _code_one(decode, v, p, q, c, k, sym, ctx, raw, bitpos, data, xs, pos, table):
    """Quantise voxel value ``v`` against its prediction ``p`` in bins of ``q`` (encoding)
    or read its bin (decoding), in context ``c``. Returns (bin, k, bitpos, xs, pos).

    Symbols: ``u`` = the bin zigzagged (0, -1, 1, -2, ... -> 0, 1, 2, 3, ...) when below
    :data:`DIRECT`; else ``DIRECT + 2 (n - 6) + h`` for ``u``'s bit length ``n`` and the
    bit ``h`` below its leading one, the ``n - 2`` bits under those going to ``raw``.
    """
    if decode:
        u, xs, pos = rans.decode_symbol(data, xs, pos, c, table)
        if u >= DIRECT:
            t = u - DIRECT
            n = 6 + (t >> 1)
            low = _get_bits(raw, bitpos, n - 2)
            bitpos += n - 2
            u = (np.int64(1) << (n - 1)) | ((t & 1) << (n - 2)) | low
        b = (u >> 1) ^ -(u & 1)
    else:
        d = np.floor((v - p) / q + 0.5)
        b = np.int64(d) if abs(d) < MAX_BIN else np.int64(0)
        u = 2 * b if b >= 0 else -2 * b - 1
        if u >= DIRECT:
            n = 64 - np.int64(leading_zeros(np.uint64(u)))
            bitpos = _put_bits(raw, bitpos, u, n - 2)
            u = DIRECT + 2 * (n - 6) + ((u >> (n - 2)) & 1)
        sym[k] = u
        ctx[k] = c
    return b, k + 1, bitpos, xs, pos


@kernel(nrt=False)
def _walk(x, rec, mag, step, kind, decode, sym, ctx, raw, data, table):
    """Predict, quantise and rebuild every voxel of ``rec``: level by level for the
    interpolations (``kind`` 0 linear, 1 cubic), in C order for Lorenzo (2: 3-D, 3: 2-D
    within each slice).

    Encoding (``decode`` 0): reads ``x``, writes the symbols and contexts into ``sym``
    and ``ctx`` and the raw bits into ``raw`` (zeroed); returns the raw bit count.
    Decoding: reads the symbols from the rANS stream ``data`` and the bits from ``raw``;
    returns 0, or -1 on a corrupt stream.
    """
    nz, ny, nx = rec.shape
    xs, pos = np.int64(0), np.int64(0)
    if decode:
        xs, pos = rans.open_state(data)
    k = 0
    bitpos = np.int64(0)
    v = 0.0
    q = step
    if kind >= 2:
        for z in range(nz):
            for y in range(ny):
                prev = 0
                for xx in range(nx):
                    p = _lorenzo(rec, z, y, xx, kind == 2)
                    a = np.int64(mag[z, y, xx - 1]) if xx else np.int64(0)
                    if y:
                        a += np.int64(mag[z, y - 1, xx])
                    if not decode:
                        v = x[z, y, xx]
                    b, k, bitpos, xs, pos = _code_one(
                        decode, v, p, q, ACT_CONTEXT[a] + prev, k,
                        sym, ctx, raw, bitpos, data, xs, pos, table,
                    )  # fmt: skip
                    rec[z, y, xx] = p + np.float64(b) * q
                    m = b if b >= 0 else -b
                    mag[z, y, xx] = min(m, 127)
                    prev = min(m, N_PREV - 1)
    else:
        top = 0
        while (1 << top) < max(nz, ny, nx):
            top += 1
        for lv in range(top, -1, -1):
            s = 1 << lv if lv < top else 0  # the anchor (0, 0, 0) first, predicted as 0
            for axis in range(3 if s else 1):
                if s == 0:
                    z0 = y0 = x0 = 0
                    sz = sy = sx = 1
                    nzz, nyy, nxx = 1, 1, 1
                    n = 1
                else:
                    z0 = s if axis == 0 else 0
                    y0 = s if axis == 1 else 0
                    x0 = s if axis == 2 else 0
                    sz = 2 * s if axis == 0 else s
                    sy = 2 * s if axis <= 1 else s
                    sx = 2 * s
                    nzz, nyy, nxx = nz, ny, nx
                    n = nz if axis == 0 else (ny if axis == 1 else nx)
                dz = s if axis == 0 else 0
                dy = s if axis == 1 else 0
                dx = s if axis == 2 else 0
                prev = 0
                for z in range(z0, nzz, sz):
                    for y in range(y0, nyy, sy):
                        for xx in range(x0, nxx, sx):
                            if s == 0:
                                p = 0.0
                                a = np.int64(0)
                            else:
                                p = _predict(rec, z, y, xx, axis, s, n, kind)
                                a = np.int64(mag[z - dz, y - dy, xx - dx])
                                i = z if axis == 0 else (y if axis == 1 else xx)
                                if i + s < n:
                                    a += np.int64(mag[z + dz, y + dy, xx + dx])
                            if not decode:
                                v = x[z, y, xx]
                            b, k, bitpos, xs, pos = _code_one(
                                decode, v, p, q, ACT_CONTEXT[a] + prev, k,
                                sym, ctx, raw, bitpos, data, xs, pos, table,
                            )  # fmt: skip
                            rec[z, y, xx] = p + np.float64(b) * q
                            m = b if b >= 0 else -b
                            mag[z, y, xx] = min(m, 127)
                            prev = min(m, N_PREV - 1)
    if decode:
        if bitpos > 8 * raw.size or not rans.state_ok(data, xs, pos):
            return -1
        return 0
    return bitpos


@kernel(inline=True)
def _lorenzo(rec, z, y, x, use_z):
    """The Lorenzo predictor over the axes with a voxel before this one (z only when
    ``use_z``): the sum over the corners of the unit cube behind it, signed by parity."""
    if x and y and (z or not use_z):  # the common case first, without the tests
        p = rec[z, y, x - 1] + rec[z, y - 1, x] - rec[z, y - 1, x - 1]
        if use_z:
            p = (
                p + rec[z - 1, y, x] - rec[z - 1, y, x - 1] - rec[z - 1, y - 1, x]
                + rec[z - 1, y - 1, x - 1]
            )  # fmt: skip
        return p
    p = 0.0
    for corner in range(1, 8):
        dz, dy, dx = corner >> 2, (corner >> 1) & 1, corner & 1
        if (dz and not (use_z and z)) or (dy and not y) or (dx and not x):
            continue
        t = rec[z - dz, y - dy, x - dx]
        p = p + t if (dz + dy + dx) & 1 else p - t
    return p


def _estimate(sym: np.ndarray, ctx: np.ndarray) -> float:
    """Bits of the static coding of ``sym`` in ``ctx`` (entropy plus about 16 bits per
    table entry): what the encoder compares its choices by."""
    counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM)
    c = counts[counts > 0].astype(np.float64)
    rows = counts.reshape(N_CTX, -1).sum(axis=1).astype(np.float64)
    rows = rows[rows > 0]
    return float((rows * np.log2(rows)).sum() - (c * np.log2(c)).sum() + 16 * c.size)


def _run(g: np.ndarray, step: float, perm, kind: int):
    xt = g.transpose(perm)  # a view: the kernel walks the permuted axes in place
    rec = np.empty(g.shape).transpose(perm)
    sym = np.empty(g.size, dtype=np.int64)
    ctx = np.empty(g.size, dtype=np.int64)
    raw = np.zeros(4 * g.size + 8, dtype=np.uint8)
    mag = np.zeros(xt.shape, dtype=np.uint8)
    z8, zt = np.zeros(1, np.uint8), np.zeros((1, 1), np.uint32)
    nbits = _walk(xt, rec, mag, step, kind, 0, sym, ctx, raw, z8, zt)
    return rec.transpose(np.argsort(perm)), sym, ctx, raw[: (nbits + 7) // 8]


def encode(g: np.ndarray, step: float, tried=TRIED):
    """Code the float64 brick ``g`` (masked voxels filled) with bins of ``step`` (= 2E).
    Returns ``(inner section, reconstruction)`` of the choice among ``tried`` ((kind,
    axis orders) pairs) estimated shortest."""
    best = None
    for kind, perms in tried:
        for perm in perms:
            rec, sym, ctx, raw = _run(g, step, perm, kind)
            bits = _estimate(sym, ctx) + 8 * raw.size
            if best is None or bits < best[0]:
                best = (bits, perm, kind, rec, sym, ctx, raw)
    _, perm, kind, rec, sym, ctx, raw = best
    counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM)
    freq = rans.normalise(counts.reshape(N_CTX, N_SYM))
    inner = (
        HEADER.pack(*perm, kind)
        + put_section(deflate(rans.pack_tables(freq)))
        + put_section(raw.tobytes())
        + rans.encode(sym, ctx, freq)
    )
    return inner, rec


def decode(inner, shape: tuple[int, int, int], step: float) -> np.ndarray:
    """The float64 reconstruction of :func:`encode`'s section (before corrections)."""
    what = "bounded brick payload (interpolation path)"
    inner = memoryview(inner)
    if len(inner) < HEADER.size:
        raise FormatError(f"{what}: the header is cut short")
    *perm, kind = HEADER.unpack_from(inner, 0)
    if sorted(perm) != [0, 1, 2] or kind > 3:
        raise FormatError(f"{what}: axis order {perm} or kind {kind} is not one of the known")
    body, pos = take_section(inner, HEADER.size, what)
    tables = inflate(body, 2 * (N_SYM + 1) * N_CTX, f"{what} tables")
    table, used = rans.unpack_tables(tables, N_CTX, N_SYM, what)
    if used != len(tables):
        raise FormatError(f"{what}: stray bytes after the rANS tables")
    raw, pos = take_section(inner, pos, what)
    data = np.frombuffer(bytes(inner[pos:]), dtype=np.uint8).copy()
    out = np.empty(shape, dtype=np.float64)
    rec = out.transpose(perm)
    mag = np.zeros(rec.shape, dtype=np.uint8)
    z = np.zeros(1, np.int64)
    raw = np.frombuffer(bytes(raw), dtype=np.uint8).copy()  # writable: one kernel type
    if _walk(rec, rec, mag, float(step), kind, 1, z, z, raw, data, table) != 0:
        raise FormatError(f"{what}: the bin stream is corrupt")
    return out
