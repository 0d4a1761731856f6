"""A static rANS coder over small alphabets, one frequency table per context.

The adaptive binary coder spends several decisions (each a multiply, a compare and a
model update) on every coefficient; when the statistics of a brick are summarised well
by a few tables fixed before coding, one table lookup per symbol does: the decoder
takes the low :data:`PROB_BITS` bits of its state as a slot, the slot's symbol from the
context's table, and updates the state with one multiply. The tables are counted by the
encoder over the whole stream, scaled to sum to ``2^PROB_BITS`` and stored ahead of it.

Symbols are coded last to first so the decoder reads them first to last. Two states
take turns (even symbols the first, odd the second), so the decoder's two chains of
dependent loads and multiplies overlap; each state is kept in ``[2^16, 2^32)`` and
renormalised 16 bits at a time, at most once a symbol (no loop, one predictable branch).
The encoder starts both states at ``2^16``, so a decoder that ends anywhere else (or not
at the stream's end) has read a corrupt stream. The layout is in ``formats/lossy-1.md``
("The rANS bin stream").

Callers whose contexts depend on decoded values (so that decoding must be interleaved
with their own work) call :func:`decode_symbol` from their kernels; :func:`pack_tables`
and :func:`unpack_tables` move the tables in and out of bytes.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel
from ..errors import FormatError

PROB_BITS = 12
TOTAL = 1 << PROB_BITS
LOW = 1 << 16  # the states' lower end
MAX_SYMBOLS = 256


def normalise(counts: np.ndarray, bits: int = PROB_BITS) -> np.ndarray:
    """Counts (one row per context) scaled so each non-empty row sums to ``2^bits``
    (``TOTAL`` by default) and every symbol seen keeps at least 1."""
    full = 1 << bits
    counts = np.asarray(counts, dtype=np.int64)
    out = np.zeros(counts.shape, dtype=np.int64)
    for c, row in enumerate(counts):
        total = int(row.sum())
        if total == 0:
            continue
        f = np.where(row > 0, np.maximum(1, np.rint(row * (full / total))), 0).astype(np.int64)
        diff = full - int(f.sum())
        while diff != 0:  # settle the rounding on the largest entries
            k = int(np.argmax(f))
            give = diff if diff > 0 else max(diff, 1 - int(f[k]))
            if give == 0:  # the largest is 1: cannot happen with <= full symbols
                raise AssertionError("rANS table does not fit")
            f[k] += give
            diff -= give
        if f.max() == full:  # one symbol: a second, never coded, keeps it below full
            k = int(np.argmax(f))
            f[k] -= 1
            f[k + 1 if k + 1 < f.size else k - 1] += 1
        out[c] = f
    return out


def pack_tables(freqs: np.ndarray) -> bytes:
    """Per context: u16 count ``m`` of the leading symbols stored, then their ``m``
    frequencies (u16); trailing zeros are left out."""
    parts = []
    for row in freqs:
        nz = np.flatnonzero(row)
        m = int(nz[-1]) + 1 if nz.size else 0
        parts.append(np.array([m], "<u2").tobytes() + row[:m].astype("<u2").tobytes())
    return b"".join(parts)


def unpack_tables(body: bytes, nctx: int, nsym: int, what: str, bits: int = PROB_BITS):
    """Read :func:`pack_tables`' bytes for ``nctx`` contexts of up to ``nsym`` symbols
    into the decoder's :func:`slot_table`; a row that is not empty and does not sum to
    ``2^bits`` is corrupt. Returns it and the bytes read."""
    freq = np.zeros((nctx, nsym), dtype=np.int64)
    words = np.frombuffer(body[: len(body) & ~1], "<u2")
    status, value = _read_tables(words, freq, 1 << bits)
    if status == 1:
        raise FormatError(f"{what}: the rANS tables are cut short")
    if status == 2:
        raise FormatError(f"{what}: a rANS table of {value} symbols runs past its data")
    if status == 3:
        raise FormatError(
            f"{what}: a rANS table sums to {value}, expected {1 << bits} over two or more symbols"
        )
    return slot_table(freq, bits), 2 * value


@kernel(nrt=False)
def _read_tables(words, freq, full):
    """The rows of :func:`pack_tables`' ``words`` into ``freq`` (zeroed), then their sums
    checked (a kernel: a brick's tables are read per decode, 15 to 40 rows, and a Python
    loop over them cost about as much as the rest of a small brick's set-up). Returns
    (0, words read), or on corrupt tables (1, 0) cut short, (2, m) a row of ``m`` symbols
    running past the words, (3, sum) the first row not summing to 0 or ``full`` or
    holding a single symbol."""
    nctx, nsym = freq.shape
    pos = 0
    for c in range(nctx):
        if pos >= words.size:
            return 1, 0
        m = np.int64(words[pos])
        pos += 1
        if m > nsym or pos + m > words.size:
            return 2, m
        for s in range(m):
            freq[c, s] = words[pos + s]
        pos += m
    for c in range(nctx):
        total, top = 0, 0
        for s in range(nsym):
            total += freq[c, s]
            top = max(top, freq[c, s])
        if (total != 0 and total != full) or top == full:
            return 3, total
    return 0, pos


def slot_table(freq: np.ndarray, bits: int = PROB_BITS) -> np.ndarray:
    """The decoder's table: for each context and slot, ``symbol | freq << 8 | (slot -
    cum) << 20`` (uint32), so one load gives all a symbol needs; empty contexts are 0."""
    out = np.zeros((freq.shape[0], 1 << bits), dtype=np.uint32)
    _fill_slots(np.ascontiguousarray(freq, dtype=np.int64), out)
    return out


@kernel
def _fill_slots(freq, out):
    for c in range(freq.shape[0]):
        slot = 0
        for s in range(freq.shape[1]):
            f = freq[c, s]
            for j in range(f):
                out[c, slot] = s | (f << 8) | (j << 20)
                slot += 1


@kernel
def encode_symbols(sym, ctx, freq, cum, out, bits):
    """Code ``sym[i]`` in table ``ctx[i]`` (frequencies summing to ``2^bits``), last to
    first, into the end of ``out``; returns the start of the stream in ``out`` (the two
    final states first), or -1 when ``out`` is too small."""
    xs = np.full(2, LOW, dtype=np.int64)
    pos = out.size
    for i in range(sym.size - 1, -1, -1):
        c, s = ctx[i], sym[i]
        f = freq[c, s]
        x = xs[i & 1]
        if x >= ((LOW >> bits) << 16) * f:
            if pos < 10:
                return -1
            pos -= 2
            out[pos] = x & 0xFF
            out[pos + 1] = (x >> 8) & 0xFF
            x >>= 16
        xs[i & 1] = ((x // f) << bits) + (x % f) + cum[c, s]
    if pos < 8:
        return -1
    for x in (xs[1], xs[0]):
        pos -= 4
        for j in range(4):
            out[pos + j] = (x >> (8 * j)) & 0xFF
    return pos


@kernel(inline=True)
def open_states(data):
    """The decoder's two states from the stream's first 8 bytes: (x0, x1, position)."""
    x0 = x1 = np.int64(0)
    if data.size >= 8:
        for j in range(4):
            x0 |= np.int64(data[j]) << (8 * j)
            x1 |= np.int64(data[4 + j]) << (8 * j)
    return x0, x1, np.int64(8)


@kernel(inline=True)
def decode_symbol(data, x, pos, c, table):
    """One symbol in context ``c`` of :func:`slot_table` with state ``x``: (symbol,
    state, position). ``data`` is the stream followed by two zero bytes (read without a
    test); past its end the state is fed zeros and :func:`state_ok` tells afterwards.
    The renormalisation has no branch: which way it goes depends on the data, and a
    mispredicted branch costs more than the arithmetic."""
    return decode_symbol_bits(data, x, pos, c, table, PROB_BITS)


@kernel(inline=True)
def decode_symbol_bits(data, x, pos, c, table, bits):
    """:func:`decode_symbol` at ``bits`` of precision (up to 12; a compile-time
    constant in the caller, so the masks fold)."""
    e = np.int64(table[c, x & ((1 << bits) - 1)])
    x, pos = _renorm(data, ((e >> 8) & 0xFFF) * (x >> bits) + (e >> 20), pos)
    return e & 0xFF, x, pos


@kernel(inline=True)
def _renorm(data, x, pos):
    """Feed the next 16-bit word to a state that fell below ``LOW`` (without a branch)."""
    more = np.int64(x < LOW)
    p = min(pos, data.size - 2)
    word = np.int64(data[p]) | (np.int64(data[p + 1]) << 8)
    return (x << (16 * more)) | (word & -more), pos + 2 * more


@kernel(inline=True)
def decode_symbol_split(data, x, pos, cbase, syms, info):
    """:func:`decode_symbol` from a table split in two (a quarter of the bytes, so more
    of it stays in the L1 cache): ``syms[cbase + slot]`` the symbol (uint8, ``cbase``
    the context's first slot in the flat array), ``info[cbase >> 4 | symbol]`` its
    frequency and first slot as ``freq | start << 13`` (uint32)."""
    s = x & (TOTAL - 1)
    t = np.int64(syms[np.uintp(cbase | s)])
    e = np.int64(info[np.uintp((cbase >> 4) | t)])
    x, pos = _renorm(data, (e & 0x1FFF) * (x >> PROB_BITS) + s - (e >> 13), pos)
    return t, x, pos


@kernel(inline=True)
def state_ok(data, x0, x1, pos):
    """Whether a decoder ended where its encoder began: at the stream's end (before the
    two padding bytes), both states at ``LOW``."""
    return x0 == LOW and x1 == LOW and pos == data.size - 2


def encode(sym: np.ndarray, ctx: np.ndarray, freq: np.ndarray, bits: int = PROB_BITS) -> bytes:
    """The stream of :func:`encode_symbols` as bytes (no tables)."""
    sym = np.ascontiguousarray(sym, dtype=np.int64)
    out = np.empty(2 * sym.size + 64, dtype=np.uint8)  # under 16 bits a symbol
    ctx = np.ascontiguousarray(ctx, dtype=np.int64)
    start = encode_symbols(sym, ctx, freq, _cum(freq), out, bits)
    if start < 0:
        raise AssertionError("rANS stream overflowed its worst-case buffer")
    return out[start:].tobytes()


def _cum(freq: np.ndarray) -> np.ndarray:
    cum = np.zeros_like(freq)
    cum[:, 1:] = np.cumsum(freq, axis=1)[:, :-1]
    return cum
