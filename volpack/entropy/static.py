"""Significance map + static rANS tables (``static``: :mod:`.arith`'s model, no adaptation).

The scan, the zero-subtree flags, the contexts and the split of a coefficient into bit
length, two bits below the leading one and plain low bits are those of :mod:`.arith2`.
What changes is that nothing adapts while decoding: the encoder counts every symbol of
the brick first, stores one frequency table per context used, and each symbol is then a
table lookup and one rANS step (:mod:`.rans`, 12-bit tables, two interleaved states).
:mod:`.arith2`'s counting and table rebuilds move to the encoder, at the cost of the
tables' bytes (a few hundred to a few thousand). Measured on the float corpus's
wavelet coefficients (README, "Lossy decoding, part 5") it decodes -1..+17 % faster
than :mod:`.arith2`: the walk (contexts from the decoded neighbours, one coefficient
after another) and not the adaptation bounds both, so it is an explicit choice only.

Contexts: the flag of a subtree in its ``(class, q)`` context (2 symbols), the bit
length in its ``(class, q)`` context (:data:`NS` symbols, the last escaping to six plain
bits as in :mod:`.arith2`), the bits below the leading one by bit length alone (2
symbols for ``n == 2``, 4 above). A table is stored as one byte per symbol on a
logarithmic scale (:func:`level_of`), so the decoder rebuilds the frequencies from the
stored levels with integer arithmetic (:func:`_scale_rows`) exactly as the encoder did.
The byte layout is in ``formats/wavelet-1.md`` (``static``).
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, leading_zeros
from ..errors import FormatError
from ..format.deflate import deflate, inflate
from . import rans
from .arith2 import (
    ESC_BITS,
    NS,
    RAW_PAD,
    context,
    gather,
    get_low_bits,
    get_raw,
    put_low_bits,
    put_raw,
    raw_end_status,
)
from .common import decoded_into, flat_view, wide
from .rans import TOTAL
from .scan import Scan

N_FLAG = 300  # (class, q) contexts: arith.N_FLAG
LEN0 = N_FLAG  # bit-length tables follow the flags' tables
MANT0 = 2 * N_FLAG  # then the tables of the bits below the leading one, by bit length
N_CTX = MANT0 + 65
NSYM = NS  # the widest alphabet
U = np.uint64

# A stored level v codes the frequency ``v`` below 32, else ``(16 + (v - 32) % 16) <<
# ((v - 32) // 16 + 1)``: 1/16 steps of an octave, so the coding loses under 0.1 %.
_VALUES = np.array(
    [v if v < 32 else (16 + (v - 32) % 16) << ((v - 32) // 16 + 1) for v in range(256)],
    dtype=np.int64,
)


def alphabet(c: int) -> int:
    """Symbols of context ``c``."""
    if c < LEN0:
        return 2
    if c < MANT0:
        return NS
    return 2 if c - MANT0 == 2 else 4


_ALPHABET = np.array([alphabet(c) for c in range(N_CTX)], dtype=np.int64)


def level_of(f: np.ndarray) -> np.ndarray:
    """The stored level nearest each frequency (0 only for 0)."""
    f = np.asarray(f, dtype=np.int64)
    hi = np.searchsorted(_VALUES[:161], f)  # _VALUES[160] = 4096 >= any frequency
    lo = np.maximum(hi - 1, 0)
    pick = np.where(f - _VALUES[lo] <= _VALUES[hi] - f, lo, hi)
    return np.where(f > 0, np.maximum(pick, 1), 0)


@kernel
def _scale_rows(levels, alpha, values, out):
    """Per context, integer frequencies summing to ``TOTAL`` from the stored levels'
    values (each level > 0 keeps at least 1; the rounding is settled on the first
    largest; a lone symbol gives 1 to its lower neighbour, or the upper one for symbol
    0); an empty row stays 0."""
    for c in range(levels.shape[0]):
        n = alpha[c]
        t = np.int64(0)
        for s in range(n):
            t += values[levels[c, s]]
        if t == 0:
            continue
        got = np.int64(0)
        k = 0
        for s in range(n):
            f = np.int64(0)
            if levels[c, s] > 0:
                f = max(np.int64(1), (values[levels[c, s]] * TOTAL) // t)
            out[c, s] = f
            got += f
            if f > out[c, k]:
                k = s
        out[c, k] += TOTAL - got
        if out[c, k] == TOTAL:
            out[c, k] -= 1
            out[c, k - 1 if k > 0 else k + 1] += 1


def _freqs(levels: np.ndarray) -> np.ndarray:
    """The frequency table (N_CTX x NSYM) the stored levels give."""
    out = np.zeros((N_CTX, NSYM), dtype=np.int64)
    _scale_rows(levels, _ALPHABET, _VALUES, out)
    return out


@kernel
def _model_kernel(flat, perm, end, parent, cls, nbr, sym, ctxs, raw):
    """The encoder's pass: each symbol and its context, the plain bits into ``raw``;
    returns (symbols, raw bytes)."""
    n = perm.size
    vals, nz = gather(flat, perm)
    nbits = np.zeros(n, dtype=np.uint8)
    acc = np.uint64(0)
    nacc = 0
    rpos = 0
    ns = 0
    nprev = 0
    i = 0
    while i < n:
        ctx, q = context(i, parent, cls, nbits, nprev, nbr)
        e = end[i]
        if e > i + 1:
            bit = np.int64(nz[e] != nz[i])
            sym[ns] = bit
            ctxs[ns] = ctx
            ns += 1
            if bit == 0:
                nprev = 0
                i = e
                continue
        c = vals[i]
        v = np.uint64((c << 1) ^ (c >> 63))
        nb = 64 - np.int64(leading_zeros(v))
        s = min(nb, NS - 1)
        sym[ns] = s
        ctxs[ns] = LEN0 + ctx
        ns += 1
        if s == NS - 1:
            acc, nacc, rpos = put_raw(raw, acc, nacc, rpos, np.uint64(nb - s), ESC_BITS)
        if nb == 2:
            sym[ns] = np.int64(v & np.uint64(1))
            ctxs[ns] = MANT0 + 2
            ns += 1
        elif nb >= 3:
            sym[ns] = np.int64(v >> np.uint64(nb - 3)) & 3
            ctxs[ns] = MANT0 + nb
            ns += 1
            acc, nacc, rpos = put_low_bits(raw, acc, nacc, rpos, v, nb)
        nbits[i] = nb
        nprev = nb
        i += 1
    if nacc > 0:
        raw[rpos] = np.uint8(acc & np.uint64(0xFF))
        rpos += 1
    return ns, rpos


def encode(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Code a coefficient array (int32 or int64) in ``scan`` order."""
    flat = wide(flat_view(coeffs))
    sym = np.empty(3 * flat.size + 8, dtype=np.int64)
    ctxs = np.empty(3 * flat.size + 8, dtype=np.int64)
    raw = np.empty(9 * flat.size + 64, dtype=np.uint8)
    ns, nraw = _model_kernel(
        flat, scan.perm, scan.end, scan.parent, scan.cls, scan.nbr, sym, ctxs, raw
    )
    sym, ctxs = sym[:ns], ctxs[:ns]
    counts = np.bincount(ctxs * NSYM + sym, minlength=N_CTX * NSYM).reshape(N_CTX, NSYM)
    tot = np.maximum(counts.sum(axis=1, keepdims=True), 1)
    levels = level_of(np.where(counts > 0, np.maximum(1, (counts * TOTAL + tot // 2) // tot), 0))
    freq = _freqs(levels)
    used = np.flatnonzero(counts.sum(axis=1))
    compact = np.full(N_CTX, -1, dtype=np.int64)
    compact[used] = np.arange(used.size)
    stream = rans.encode(sym, compact[ctxs], freq[used])
    tables = _pack_levels(levels)
    return (
        len(tables).to_bytes(4, "little") + tables
        + len(stream).to_bytes(4, "little") + stream + raw[:nraw].tobytes()
    )  # fmt: skip


def _pack_levels(levels: np.ndarray) -> bytes:
    """Per context: the count ``m`` of leading levels kept, then those ``m`` bytes."""
    parts = bytearray()
    for row in levels:
        nz = np.flatnonzero(row)
        m = int(nz[-1]) + 1 if nz.size else 0
        parts.append(m)
        parts += row[:m].astype(np.uint8).tobytes()
    return deflate(parts)


def _unpack_levels(body: bytes) -> np.ndarray:
    raw = np.frombuffer(inflate(body, N_CTX * (NSYM + 1), "static-coded brick tables"), np.uint8)
    levels = np.zeros((N_CTX, NSYM), dtype=np.int64)
    status = _read_levels(raw, _ALPHABET, levels)
    if status:
        why = ("the tables are cut short", "a table is too wide", "bytes follow the tables")
        raise FormatError(f"corrupt static-coded brick: {why[status - 1]}")
    return levels


@kernel
def _read_levels(raw, alpha, levels):
    pos = 0
    for c in range(levels.shape[0]):
        if pos >= raw.size:
            return 1
        m = np.int64(raw[pos])
        if m > alpha[c] or pos + 1 + m > raw.size:
            return 2
        for s in range(m):
            levels[c, s] = raw[pos + 1 + s]
        pos += 1 + m
    return 3 if pos != raw.size else 0


@kernel
def _slots(freq, syms, info):
    """The split decoder table of :func:`.rans.decode_symbol_split`."""
    for c in range(freq.shape[0]):
        slot = 0
        for s in range(freq.shape[1]):
            f = freq[c, s]
            info[(c << 8) | s] = np.uint32(f | (slot << 13))
            for _ in range(f):
                syms[(c << 12) | slot] = s
                slot += 1


@kernel(nrt=False)
def _decode_kernel(data, raw, perm, end, parent, cls, nbr, flat, nmax, cmap, syms, info, nbits):
    """Return 0 on success, 1 when a stream ran short, 2 on an impossible symbol, 3 when
    it does not end where its length says."""
    n = perm.size
    x, y, pos = rans.open_states(data)
    bitpos = 0
    rawbits = (raw.size - RAW_PAD) * 8
    nprev = 0
    i = 0
    while i < n:
        if bitpos > rawbits:
            return 1
        ctx, q = context(i, parent, cls, nbits, nprev, nbr)
        e = end[U(i)]
        if e > i + 1:
            k = cmap[U(ctx)]
            if k < 0:
                return 2
            bit, x, pos = rans.decode_symbol_split(data, x, pos, k << 12, syms, info)
            x, y = y, x
            if bit == 0:  # the caller zeroed ``flat``
                nprev = 0
                i = e
                continue
        k = cmap[U(LEN0 + ctx)]
        if k < 0:
            return 2
        nb, x, pos = rans.decode_symbol_split(data, x, pos, k << 12, syms, info)
        x, y = y, x
        if nb == NS - 1:
            d, bitpos = get_raw(raw, bitpos, ESC_BITS)
            nb += np.int64(d)
            if nb > nmax:
                return 2
        if nb >= 2:
            k = cmap[U(MANT0 + nb)]
            if k < 0:
                return 2
            m, x, pos = rans.decode_symbol_split(data, x, pos, k << 12, syms, info)
            x, y = y, x
            if nb == 2:
                v = np.uint64(2 | m)
            else:
                v, bitpos = get_low_bits(raw, bitpos, np.uint64(4 | m), nb)
        else:
            v = np.uint64(nb)
        flat[U(perm[U(i)])] = np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))
        nbits[U(i)] = nb
        nprev = nb
        i += 1
    status = raw_end_status(raw, bitpos)
    if status:
        return status
    if not rans.state_ok(data, x, y, pos):
        return 3 if pos <= data.size - 2 else 1
    return 0


def decode(data: bytes, scan: Scan, out: np.ndarray) -> None:
    """Decode ``data`` into ``out`` (a C-contiguous int32/int64 array, overwritten)."""
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    data = bytes(data)
    parts = []
    pos = 0
    for what in ("tables", "rANS stream"):
        if pos + 4 > len(data):
            raise FormatError(f"corrupt static-coded brick: no length of its {what}")
        k = int.from_bytes(data[pos : pos + 4], "little")
        if pos + 4 + k > len(data):
            raise FormatError(f"corrupt static-coded brick: its {what} run past the payload")
        parts.append(data[pos + 4 : pos + 4 + k])
        pos += 4 + k
    freq = _freqs(_unpack_levels(parts[0]))
    used = np.flatnonzero(freq.any(axis=1))
    cmap = np.full(N_CTX, -1, dtype=np.int64)
    cmap[used] = np.arange(used.size)
    syms = np.zeros(used.size << 12, dtype=np.uint8)
    info = np.zeros(used.size << 8, dtype=np.uint32)
    _slots(freq[used], syms, info)
    stream = np.zeros(len(parts[1]) + 2, dtype=np.uint8)  # two bytes of padding
    stream[: len(parts[1])] = np.frombuffer(parts[1], np.uint8)
    raw = np.zeros(len(data) - pos + RAW_PAD, dtype=np.uint8)
    raw[: len(data) - pos] = np.frombuffer(data, np.uint8, len(data) - pos, pos)
    nbits = np.zeros(flat.size, dtype=np.uint8)
    decoded_into(
        flat,
        lambda into, nmax: _decode_kernel(
            stream, raw, scan.perm, scan.end, scan.parent, scan.cls, scan.nbr, into,
            nmax, cmap, syms, info, nbits,
        ),
        "static",
        zeroed=True,  # zero subtrees are skipped, not written
    )  # fmt: skip
