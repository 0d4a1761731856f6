"""Static rANS: table-driven entropy coding of small symbols, several contexts, two states.

The adaptive binary range coder (:mod:`.rangecoder`) pays one multiply, one compare and
one model update per binary decision, and a residual takes several. A static range
variant of asymmetric numeral systems (rANS) codes a whole symbol with one table look-up
and one multiply: the encoder counts the symbols of a brick per context first, scales
the counts to frequencies summing to ``M = 2^PROB_BITS`` (:func:`normalize`), stores
them (the caller's format), and codes the symbols backwards; the decoder turns the
tables into one ``M``-entry look-up per context (:func:`spread`) and reads the
symbols forwards.

State: a 32-bit integer in ``[L, 2^32)`` with ``L = 2^16``, renormalised by 16-bit words
(at most one word per symbol, as ``M <= 2^16``). A coder may keep several states and
use them in turn over one word stream; the decoder then runs as many independent
dependency chains, which a CPU overlaps. The steps are inline kernels
(:func:`put`, :func:`get`) for the coders' own loops.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel

PROB_BITS = 12
M = 1 << PROB_BITS
RANS_L = 1 << 16  # lower end of the state interval; also its initial and final value
NSYM = 256  # symbols are bytes
BAD_SYMBOL = 0xFF  # what a slot of an unused context decodes to (never a coded symbol)


@kernel(inline=True)
def put(words, wpos, x, f, start):
    """Encode a symbol of frequency ``f`` starting at ``start`` into state ``x`` (the
    encoder runs backwards; ``words`` fills from the end): returns ``(x, wpos)``."""
    if x >= (f << (32 - PROB_BITS)):
        wpos -= 1
        words[wpos] = x & 0xFFFF
        x >>= 16
    q = x // f
    return (q << PROB_BITS) + x - q * f + start, wpos


@kernel(inline=True)
def get(table, base, words, rpos, x):
    """Decode one symbol from state ``x`` with the look-up ``table[base:base + M]``:
    returns ``(symbol, x, rpos)``. ``words`` ends with one 0 word past the stream, which
    every read beyond the end gets (the caller's end check refuses such a stream);
    indices are unsigned (no wrap-around test)."""
    e = np.int64(table[np.uintp(base + (x & (M - 1)))])
    x = ((e >> 20) + 1) * (x >> PROB_BITS) + ((e >> 8) & (M - 1))
    if x < RANS_L:
        x = (x << 16) | np.int64(words[np.uintp(min(rpos, words.size - 1))])
        rpos += 1
    return e & 0xFF, x, rpos


def normalize(counts: np.ndarray) -> np.ndarray:
    """Frequencies summing to ``M`` from symbol counts (one row per context): every
    counted symbol keeps at least 1; rows without counts stay zero. The rounding
    remainder goes to (or comes from) the most frequent symbols, where it costs least."""
    counts = np.asarray(counts, dtype=np.int64)
    total = counts.sum(axis=1, keepdims=True)
    f = np.where(counts > 0, np.maximum(counts * M // np.maximum(total, 1), 1), 0)
    for c in np.flatnonzero(total[:, 0]):
        row = f[c]
        diff = M - int(row.sum())
        for k in np.argsort(-counts[c], kind="stable"):
            if diff == 0:
                break
            step = diff if diff > 0 else max(diff, 1 - int(row[k]))
            row[k] += step
            diff -= step
    return f


def starts(freqs: np.ndarray) -> np.ndarray:
    """Cumulative starts of each symbol's slots (same shape as ``freqs``)."""
    return np.cumsum(freqs, axis=1) - freqs


def cost_bits(counts: np.ndarray, freqs: np.ndarray) -> float:
    """Bits the coded symbols take with these frequencies (tables and words aside)."""
    used = counts > 0
    return float(-(counts[used] * np.log2(freqs[used] / M)).sum())


@kernel(inline=True)
def spread(table, base, start, f, sym):
    """Give symbol ``sym`` (frequency ``f``, slots from ``start``) its slots of the
    decoder's look-up ``table[base:base + M]``: each entry packs
    ``(f - 1) << 20 | (slot - start) << 8 | sym``, what :func:`get` needs."""
    for j in range(start, start + f):
        table[base + j] = ((f - 1) << 20) | ((j - start) << 8) | sym
