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

from .._jit import kernel, leading_zeros
from ..errors import FormatError
from .common import decoded_into, encode_with_retry, flat_view, wide
from .scan import Scan


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
    return 64 - np.int64(leading_zeros(v))


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
def _peek(words, bitpos):
    """The 64 bits from ``bitpos`` on, first bit on top.

    ``words`` is the stream as big-endian 64-bit words with two zero words of padding;
    callers keep ``bitpos`` within the real stream, so both loads stay in the array.
    """
    wi = bitpos >> 6
    off = np.uint64(bitpos & 63)
    # Two shifts for the low word: a shift by 64 (off == 0) is undefined.
    return (words[wi] << off) | ((words[wi + 1] >> np.uint64(1)) >> (np.uint64(63) - off))


@kernel(inline=True)
def _get_code(data, bitpos, limit, nmax):
    """Read one fixed code at ``bitpos``; returns (value, ok, new bitpos)."""
    w = _peek(data, bitpos)
    ones = leading_zeros(~w)
    if ones == 0:
        return np.uint64(0), True, bitpos + 1
    if ones <= 32:  # the whole 2n-bit code lies in this word
        if ones > nmax:
            return np.uint64(0), False, bitpos
        v = np.uint64(1) << np.uint64(ones - 1)
        if ones >= 2:
            v |= (w << np.uint64(ones + 1)) >> np.uint64(65 - ones)
        return v, True, bitpos + 2 * ones
    n = 0
    while True:
        if bitpos > limit:
            return np.uint64(0), False, bitpos
        k = leading_zeros(~_peek(data, bitpos))
        if k < 56:
            n += k
            bitpos += k + 1
            break
        n += 56
        bitpos += 56
        if n > nmax:
            return np.uint64(0), False, bitpos
    if n > nmax:
        return np.uint64(0), False, bitpos
    v = np.uint64(1)
    rest = n - 1
    while rest > 0:
        if bitpos > limit:
            return np.uint64(0), False, bitpos
        k = min(rest, 48)
        rest -= k
        bits = _peek(data, bitpos) >> np.uint64(64 - k)
        bitpos += k
        v = (v << np.uint64(k)) | bits
    return v, True, bitpos


@kernel(inline=True)
def _end_status(data, bitpos, limit):
    """0 when the last code ends in the stream's last byte and the padding is zero bits
    (what the encoder's flush leaves), 1 when it ran past the end, 3 otherwise."""
    if bitpos > limit:
        return 1
    pad = limit - bitpos
    if pad >= 8 or (pad > 0 and _peek(data, bitpos) >> np.uint64(64 - pad) != 0):
        return 3
    return 0


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
    nz = np.zeros(n + 1, dtype=np.int32)
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
def _huffman_decode_kernel(data, limit, perm, end, flat, nmax):
    n = perm.size
    bitpos = 0
    i = 0
    while i < n:
        if bitpos > limit:
            return 1
        e = end[i]
        if e > i + 1:
            flag = _peek(data, bitpos) >> np.uint64(63)
            bitpos += 1
            if flag:
                for j in range(i, e):
                    flat[perm[j]] = 0
                i = e
                continue
        v, ok, bitpos = _get_code(data, bitpos, limit, nmax)
        if not ok:
            return 2
        flat[perm[i]] = _unmapped(v)
        i += 1
    return _end_status(data, bitpos, limit)


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
def _rle_decode_kernel(data, limit, perm, flat, nmax):
    n = perm.size
    bitpos = 0
    i = 0
    while i < n:
        if bitpos > limit:
            return 1
        run, ok, bitpos = _get_code(data, bitpos, limit, 40)
        if not ok or run > np.uint64(n - i):
            return 2
        for j in range(i, i + np.int64(run)):
            flat[perm[j]] = 0
        i += np.int64(run)
        if i == n:
            break
        if bitpos > limit:
            return 1
        v, ok, bitpos = _get_code(data, bitpos, limit, nmax)
        if not ok:
            return 2
        flat[perm[i]] = _unmapped(v + np.uint64(1))
        i += 1
    return _end_status(data, bitpos, limit)


def encode_huffman(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Subtree flags + fixed code, in ``scan`` order."""
    flat = wide(flat_view(coeffs))
    return encode_with_retry(
        lambda out: _huffman_encode_kernel(flat, scan.perm, scan.end, out), flat.size
    )


def decode_huffman(data: bytes, scan: Scan, out: np.ndarray) -> None:
    flat = _checked(out, scan)
    words, limit = _words(data)
    decoded_into(
        flat,
        lambda into, nmax: _huffman_decode_kernel(words, limit, scan.perm, scan.end, into, nmax),
        "huffman",
        zeroed=False,  # every coefficient is written
    )


def encode_rle(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Zero runs + fixed code, in ``scan`` order (subtree structure unused)."""
    flat = wide(flat_view(coeffs))
    return encode_with_retry(lambda out: _rle_encode_kernel(flat, scan.perm, out), flat.size)


def decode_rle(data: bytes, scan: Scan, out: np.ndarray) -> None:
    flat = _checked(out, scan)
    words, limit = _words(data)
    decoded_into(
        flat,
        lambda into, nmax: _rle_decode_kernel(words, limit, scan.perm, into, nmax),
        "rle",
        zeroed=False,  # every coefficient is written
    )


def _words(data: bytes) -> tuple[np.ndarray, int]:
    """The stream as native uint64 words read big-endian, plus two zero words; and its
    length in bits."""
    nw = (len(data) + 7) // 8 + 2
    buf = np.zeros(nw * 8, dtype=np.uint8)
    buf[: len(data)] = np.frombuffer(data, dtype=np.uint8)
    return buf.view(">u8").astype(np.uint64), len(data) * 8


def _checked(out: np.ndarray, scan: Scan) -> np.ndarray:
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    return flat
