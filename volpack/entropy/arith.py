"""Significance map + adaptive binary arithmetic coding (the best-ratio coder).

Coefficients are visited in the scan order of :mod:`volpack.sigmap` and mapped to
unsigned integers ``m`` (``c >= 0 -> 2c``, ``c < 0 -> -2c - 1``). For each position:

1. If the position roots a subtree (dfs scan), one binary flag says whether the whole
   subtree is zero; if so it is skipped. These flags are the significance map.
2. The bit length ``n`` of ``m`` (0 for a zero) is coded MSB first through a 6-level
   binary tree of adaptive probabilities, chosen by context: the subband class and a
   quantised estimate of the local magnitude from the parent and the two previously
   coded coefficients.
3. The three bits below the leading one are coded with adaptive probabilities per
   ``(n, bits so far, class)``: within one bit length, small values are likelier. The
   remaining low bits (the sign in the last place) are coded at probability one half.

The arithmetic coder is a binary range coder with 12-bit probabilities, a 32-bit range
and byte-wise carry propagation: one multiply per decision and no division. Each
probability adapts fast while young and settles as it is used. The stream layout is given
in ``formats/wavelet-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..errors import FormatError
from ..sigmap import N_CLASSES, Scan
from .common import check_status, encode_with_retry, flat_view, max_bits

PROB_BITS = 12
PROB_INIT = 1 << (PROB_BITS - 1)
TOP = 1 << 24
TREE_BITS = 6  # bit lengths 0..63
NQ = 12  # quantised local-magnitude contexts
# A probability moves by 1/2**RATE[k] of its distance to 0 or 1 on its k-th use: fast
# while it has seen little (a running average), then settling at 1/16 (bricks are small).
RATE = np.array([1, 2, 2, 3, 3, 3, 3] + [4] * 24 + [5], dtype=np.int64)
N_RATE = RATE.size - 1
N_FLAG = N_CLASSES * NQ
N_TREE = N_FLAG << TREE_BITS
MANT_BITS = 3  # bits below the leading one that get adaptive probabilities
N_MANT = (64 << MANT_BITS) * N_CLASSES


@kernel(inline=True)
def _adapt(prob, used, k, bit):
    p = np.int64(prob[k])
    u = used[k]
    r = RATE[u]
    if u < N_RATE:
        used[k] = u + 1
    if bit:
        prob[k] = p - (p >> r)
    else:
        prob[k] = p + (((1 << PROB_BITS) - p) >> r)


@kernel(inline=True)
def _shift_low(low, cache, csize, out, pos):
    if low < 0xFF000000 or low >= 0x100000000:
        carry = low >> 32
        temp = cache
        while True:
            out[pos] = (temp + carry) & 0xFF
            pos += 1
            temp = 0xFF
            csize -= 1
            if csize == 0:
                break
        cache = (low >> 24) & 0xFF
    csize += 1
    low = (low & 0x00FFFFFF) << 8
    return low, cache, csize, pos


@kernel(inline=True)
def _put_bit(prob, used, k, bit, low, rng, cache, csize, out, pos):
    bound = (rng >> PROB_BITS) * np.int64(prob[k])
    if bit:
        low += bound
        rng -= bound
    else:
        rng = bound
    _adapt(prob, used, k, bit)
    while rng < TOP:
        rng <<= 8
        low, cache, csize, pos = _shift_low(low, cache, csize, out, pos)
    return low, rng, cache, csize, pos


@kernel(inline=True)
def _get_bit(prob, used, k, code, rng, data, pos):
    bound = (rng >> PROB_BITS) * np.int64(prob[k])
    bit = code >= bound
    if bit:
        code -= bound
        rng -= bound
    else:
        rng = bound
    _adapt(prob, used, k, bit)
    while rng < TOP:
        rng <<= 8
        code = ((code << 8) | (np.int64(data[pos]) if pos < data.size else 0)) & 0xFFFFFFFF
        pos += 1
    return bit, code, rng, pos


@kernel(inline=True)
def _context(i, parent, cls, nbits, nprev, nprev2):
    p = parent[i]
    npar = nbits[p] if p >= 0 else nprev
    q = (2 * npar + nprev + nprev2 + 2) >> 2
    if q >= NQ:
        q = NQ - 1
    return np.int64(cls[i]) * NQ + q


@kernel
def _encode_kernel(flat, perm, end, parent, cls, out):
    n = perm.size
    m = np.empty(n, dtype=np.uint64)
    nz = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        c = np.int64(flat[perm[i]])
        m[i] = np.uint64((c << 1) ^ (c >> 63))
        nz[i + 1] = nz[i] + (c != 0)
    prob = np.full(N_FLAG + N_TREE + N_MANT, PROB_INIT, dtype=np.uint16)
    used = np.zeros(prob.size, dtype=np.uint8)
    nbits = np.zeros(n, dtype=np.int64)
    cap = out.size
    low = np.int64(0)
    rng = np.int64(0xFFFFFFFF)
    cache = np.int64(0)
    csize = np.int64(1)
    pos = 0
    nprev = 0
    nprev2 = 0
    i = 0
    while i < n:
        if pos + 32 > cap:
            return -1
        ctx = _context(i, parent, cls, nbits, nprev, nprev2)
        e = end[i]
        if e > i + 1:
            zero = nz[e] == nz[i]
            low, rng, cache, csize, pos = _put_bit(
                prob, used, ctx, not zero, low, rng, cache, csize, out, pos
            )
            if zero:
                nprev2 = nprev
                nprev = 0
                i = e
                continue
        v = m[i]
        nb = 0
        while nb < 64 and (v >> np.uint64(nb)) != 0:
            nb += 1
        node = 1
        base = N_FLAG + (ctx << TREE_BITS)
        for b in range(TREE_BITS - 1, -1, -1):
            bit = (nb >> b) & 1
            low, rng, cache, csize, pos = _put_bit(
                prob, used, base + node, bit, low, rng, cache, csize, out, pos
            )
            node = 2 * node + bit
        # The top bits below the leading one, modelled; the rest (sign last) at 1/2.
        modelled = min(nb - 1, MANT_BITS)
        prefix = 1
        for b in range(nb - 2, nb - 2 - modelled, -1):
            bit = np.int64((v >> np.uint64(b)) & np.uint64(1))
            k = N_FLAG + N_TREE + ((nb << MANT_BITS) + prefix) * N_CLASSES + cls[i]
            low, rng, cache, csize, pos = _put_bit(
                prob, used, k, bit, low, rng, cache, csize, out, pos
            )
            prefix = 2 * prefix + bit
        for b in range(nb - 2 - modelled, -1, -1):
            rng >>= 1
            if (v >> np.uint64(b)) & np.uint64(1):
                low += rng
            if rng < TOP:
                rng <<= 8
                low, cache, csize, pos = _shift_low(low, cache, csize, out, pos)
        nbits[i] = nb
        nprev2 = nprev
        nprev = nb
        i += 1
    for _ in range(5):
        low, cache, csize, pos = _shift_low(low, cache, csize, out, pos)
    return pos


@kernel
def _decode_kernel(data, perm, end, parent, cls, flat, nmax):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible symbol."""
    n = perm.size
    size = data.size
    prob = np.full(N_FLAG + N_TREE + N_MANT, PROB_INIT, dtype=np.uint16)
    used = np.zeros(prob.size, dtype=np.uint8)
    nbits = np.zeros(n, dtype=np.int64)
    rng = np.int64(0xFFFFFFFF)
    code = np.int64(0)
    pos = 1  # the encoder's first byte is always zero
    for _ in range(4):
        code = (code << 8) | (np.int64(data[pos]) if pos < size else 0)
        pos += 1
    nprev = 0
    nprev2 = 0
    i = 0
    while i < n:
        if pos > size + 4:
            return 1
        ctx = _context(i, parent, cls, nbits, nprev, nprev2)
        e = end[i]
        if e > i + 1:
            live, code, rng, pos = _get_bit(prob, used, ctx, code, rng, data, pos)
            if not live:
                for j in range(i, e):
                    flat[perm[j]] = 0
                nprev2 = nprev
                nprev = 0
                i = e
                continue
        node = 1
        base = N_FLAG + (ctx << TREE_BITS)
        for _ in range(TREE_BITS):
            bit, code, rng, pos = _get_bit(prob, used, base + node, code, rng, data, pos)
            node = 2 * node + bit
        nb = node - (1 << TREE_BITS)
        if nb > nmax:
            return 2
        v = np.uint64(1 if nb >= 1 else 0)
        modelled = min(nb - 1, MANT_BITS)
        prefix = 1
        for _ in range(modelled):
            k = N_FLAG + N_TREE + ((nb << MANT_BITS) + prefix) * N_CLASSES + cls[i]
            bit, code, rng, pos = _get_bit(prob, used, k, code, rng, data, pos)
            prefix = 2 * prefix + bit
            v = (v << np.uint64(1)) | np.uint64(bit)
        for _ in range(nb - 1 - modelled):
            rng >>= 1
            bit = code >= rng
            if bit:
                code -= rng
            v = (v << np.uint64(1)) | np.uint64(bit)
            if rng < TOP:
                rng <<= 8
                code = ((code << 8) | (np.int64(data[pos]) if pos < size else 0)) & 0xFFFFFFFF
                pos += 1
        flat[perm[i]] = np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))
        nbits[i] = nb
        nprev2 = nprev
        nprev = nb
        i += 1
    if pos > size + 4:
        return 1
    return 0


def encode(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Code a coefficient array (int32 or int64) in ``scan`` order."""
    flat = flat_view(coeffs)
    return encode_with_retry(
        lambda out: _encode_kernel(flat, scan.perm, scan.end, scan.parent, scan.cls, out),
        flat.size,
    )


def decode(data: bytes, scan: Scan, out: np.ndarray) -> None:
    """Decode ``data`` into ``out`` (a C-contiguous int32/int64 array, overwritten)."""
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    buf = np.frombuffer(data, dtype=np.uint8)
    status = _decode_kernel(buf, scan.perm, scan.end, scan.parent, scan.cls, flat, max_bits(flat))
    check_status(status, "arithmetic")
