"""The fixed prefix code, used two ways: after a significance map, and after zero runs.

The code of an unsigned value ``m`` with bit length ``n`` is ``n`` one-bits, a zero bit,
then the ``n - 1`` bits of ``m`` below its leading one: ``0 -> 0``, ``1 -> 10``,
``2 -> 1100``, ``3 -> 1101``, ``4..7 -> 1110xx``. It needs no table, so nothing is
stored or adapted and decoding is a leading-ones count plus a bit read.

``huffman``
    The dfs scan's subtree flags (1 bit: the subtree is all zero and skipped) plus the
    code of every surviving coefficient's mapped value.
``rle``
    For each non-zero coefficient in scan order, the code of the zero run before it and
    the code of ``m - 1``; a final run covers trailing zeros. Wins when almost
    everything is zero.

Bits are packed most significant first; see ``formats/wavelet-1.md``.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..errors import FormatError
from ..sigmap import Scan
from .common import check_status, encode_with_retry, flat_view, max_bits

# Leading one-bits of a byte, for the decoder's unary count.
_LEAD = np.array([8 - len(f"{(~b) & 0xFF:08b}".lstrip("0")) for b in range(256)], np.int64)


@kernel(inline=True)
def _put(out, pos, acc, nacc, value, nbits):
    acc = ((acc << nbits) | value) & ((np.int64(1) << (nacc + nbits)) - 1)
    nacc += nbits
    while nacc >= 8:
        nacc -= 8
        out[pos] = (acc >> nacc) & 0xFF
        pos += 1
    acc &= (np.int64(1) << nacc) - 1
    return pos, acc, nacc


@kernel(inline=True)
def _bitlen(v):
    n = 0
    while n < 64 and (v >> np.uint64(n)) != 0:
        n += 1
    return n


@kernel(inline=True)
def _put_code(out, pos, acc, nacc, v):
    """Write the fixed code of ``v`` (uint64)."""
    n = _bitlen(v)
    if n == 0:
        return _put(out, pos, acc, nacc, np.int64(0), 1)
    low = np.int64(v - (np.uint64(1) << np.uint64(n - 1)))
    if n <= 15:
        word = ((np.int64(1) << (n + 1)) - 2) << (n - 1) | low
        return _put(out, pos, acc, nacc, word, 2 * n)
    ones = n
    while ones > 0:
        k = min(ones, 24)
        pos, acc, nacc = _put(out, pos, acc, nacc, (np.int64(1) << k) - 1, k)
        ones -= k
    pos, acc, nacc = _put(out, pos, acc, nacc, np.int64(0), 1)
    rest = n - 1
    while rest > 0:
        k = min(rest, 24)
        rest -= k
        pos, acc, nacc = _put(out, pos, acc, nacc, (low >> rest) & ((np.int64(1) << k) - 1), k)
    return pos, acc, nacc


@kernel(inline=True)
def _flush(out, pos, acc, nacc):
    if nacc > 0:
        out[pos] = (acc << (8 - nacc)) & 0xFF
        pos += 1
    return pos


@kernel(inline=True)
def _refill(data, pos, buf, nbuf):
    while nbuf <= 48:
        byte = np.int64(data[pos]) if pos < data.size else 0
        buf = ((buf << 8) | byte) & ((np.int64(1) << (nbuf + 8)) - 1)
        nbuf += 8
        pos += 1
    return pos, buf, nbuf


@kernel(inline=True)
def _get_code(data, pos, buf, nbuf, lead, nmax):
    """Read one fixed code; returns (value, ok, pos, buf, nbuf)."""
    pos, buf, nbuf = _refill(data, pos, buf, nbuf)
    ones = lead[(buf >> (nbuf - 8)) & 0xFF]
    if ones < 8 and ones <= nmax:  # short codes: one refill covers the whole code
        if ones == 0:
            return np.uint64(0), True, pos, buf, nbuf - 1
        nbuf -= ones + ones
        low = (buf >> nbuf) & ((np.int64(1) << (ones - 1)) - 1)
        return np.uint64(low | (np.int64(1) << (ones - 1))), True, pos, buf, nbuf
    n = 0
    while True:
        pos, buf, nbuf = _refill(data, pos, buf, nbuf)
        ones = lead[(buf >> (nbuf - 8)) & 0xFF]
        if ones < 8:
            n += ones
            nbuf -= ones + 1
            break
        n += 8
        nbuf -= 8
        if n > nmax:
            return np.uint64(0), False, pos, buf, nbuf
    if n == 0:
        return np.uint64(0), True, pos, buf, nbuf
    if n > nmax:
        return np.uint64(0), False, pos, buf, nbuf
    v = np.uint64(1)
    rest = n - 1
    while rest > 0:
        k = min(rest, 24)
        rest -= k
        pos, buf, nbuf = _refill(data, pos, buf, nbuf)
        nbuf -= k
        bits = (buf >> nbuf) & ((np.int64(1) << k) - 1)
        v = (v << np.uint64(k)) | np.uint64(bits)
    return v, True, pos, buf, nbuf


@kernel(inline=True)
def _mapped(flat, j):
    c = np.int64(flat[j])
    return np.uint64((c << 1) ^ (c >> 63))


@kernel(inline=True)
def _unmapped(v):
    return np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))


@kernel
def _huffman_encode_kernel(flat, perm, end, out):
    n = perm.size
    nz = np.zeros(n + 1, dtype=np.int64)
    for i in range(n):
        nz[i + 1] = nz[i] + (flat[perm[i]] != 0)
    cap = out.size
    pos = 0
    acc = np.int64(0)
    nacc = 0
    i = 0
    while i < n:
        if pos + 24 > cap:
            return -1
        e = end[i]
        if e > i + 1:
            zero = nz[e] == nz[i]
            pos, acc, nacc = _put(out, pos, acc, nacc, np.int64(1 if zero else 0), 1)
            if zero:
                i = e
                continue
        pos, acc, nacc = _put_code(out, pos, acc, nacc, _mapped(flat, perm[i]))
        i += 1
    return _flush(out, pos, acc, nacc)


@kernel
def _huffman_decode_kernel(data, perm, end, flat, lead, nmax):
    n = perm.size
    pos = 0
    buf = np.int64(0)
    nbuf = 0
    i = 0
    while i < n:
        e = end[i]
        if e > i + 1:
            pos, buf, nbuf = _refill(data, pos, buf, nbuf)
            nbuf -= 1
            if (buf >> nbuf) & 1:
                for j in range(i, e):
                    flat[perm[j]] = 0
                i = e
                continue
        v, ok, pos, buf, nbuf = _get_code(data, pos, buf, nbuf, lead, nmax)
        if not ok:
            return 2
        flat[perm[i]] = _unmapped(v)
        i += 1
    # Bits consumed must lie within the stream (refills read ahead up to 7 bytes).
    if (pos * 8 - nbuf) > data.size * 8:
        return 1
    return 0


@kernel
def _rle_encode_kernel(flat, perm, out):
    n = perm.size
    cap = out.size
    pos = 0
    acc = np.int64(0)
    nacc = 0
    run = 0
    for i in range(n):
        v = _mapped(flat, perm[i])
        if v == 0:
            run += 1
            continue
        if pos + 48 > cap:
            return -1
        pos, acc, nacc = _put_code(out, pos, acc, nacc, np.uint64(run))
        pos, acc, nacc = _put_code(out, pos, acc, nacc, v - np.uint64(1))
        run = 0
    if run > 0:
        pos, acc, nacc = _put_code(out, pos, acc, nacc, np.uint64(run))
    return _flush(out, pos, acc, nacc)


@kernel
def _rle_decode_kernel(data, perm, flat, lead, nmax):
    n = perm.size
    pos = 0
    buf = np.int64(0)
    nbuf = 0
    i = 0
    while i < n:
        run, ok, pos, buf, nbuf = _get_code(data, pos, buf, nbuf, lead, 40)
        if not ok or run > np.uint64(n - i):
            return 2
        for j in range(i, i + np.int64(run)):
            flat[perm[j]] = 0
        i += np.int64(run)
        if i == n:
            break
        v, ok, pos, buf, nbuf = _get_code(data, pos, buf, nbuf, lead, nmax)
        if not ok or v == np.uint64(0xFFFFFFFFFFFFFFFF):
            return 2
        flat[perm[i]] = _unmapped(v + np.uint64(1))
        i += 1
    if (pos * 8 - nbuf) > data.size * 8:
        return 1
    return 0


def encode_huffman(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Subtree flags + fixed code, in ``scan`` order."""
    flat = flat_view(coeffs)
    return encode_with_retry(
        lambda out: _huffman_encode_kernel(flat, scan.perm, scan.end, out), flat.size
    )


def decode_huffman(data: bytes, scan: Scan, out: np.ndarray) -> None:
    flat = _checked(out, scan)
    buf = np.frombuffer(data, dtype=np.uint8)
    check_status(
        _huffman_decode_kernel(buf, scan.perm, scan.end, flat, _LEAD, max_bits(flat)), "huffman"
    )


def encode_rle(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Zero runs + fixed code, in ``scan`` order (subtree structure unused)."""
    flat = flat_view(coeffs)
    return encode_with_retry(lambda out: _rle_encode_kernel(flat, scan.perm, out), flat.size)


def decode_rle(data: bytes, scan: Scan, out: np.ndarray) -> None:
    flat = _checked(out, scan)
    buf = np.frombuffer(data, dtype=np.uint8)
    check_status(_rle_decode_kernel(buf, scan.perm, flat, _LEAD, max_bits(flat)), "rle")


def _checked(out: np.ndarray, scan: Scan) -> np.ndarray:
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    return flat
