"""Significance map + adaptive multi-symbol rANS (``arith2``: ``arith``'s model, decoded
about twice as fast).

The scan, the zero-subtree flags and the contexts are those of :mod:`.arith`; what
changes is how each coefficient is coded. :mod:`.arith` spends about 4.4 adaptive binary
decisions per coefficient, each a serial step of the range coder. Here:

1. the bit length ``n`` of the mapped coefficient ``m`` is ONE symbol (0..19, 19 escaping
   to ``19 + `` six plain bits) of an adaptive frequency table per context ``(class, q)``;
2. the two bits below the leading one are one 4-ary symbol of a table per ``(n, class)``
   (for ``n == 2`` the one bit is a binary decision, as the flags);
3. the remaining low bits go to a separate plain bit stream, read with shifts.

Tables keep counts and are rebuilt into cumulative bounds (15 bits, each symbol at least
1) on a doubling schedule, then every :data:`STEP` uses; counts halve past
:data:`LIMIT`. Bounds are 16-bit lanes of 64-bit words, so the decoder finds a symbol by
comparing its slot with four bounds at a time. The symbols are coded by two interleaved
rANS states (a step is a mask, a multiply and an add, and the two chains overlap); the
encoder runs the models forward, recording each symbol's interval, then codes them last
to first. The byte layout is in ``formats/wavelet-1.md`` (``arith2``).

Decoder loops index with unsigned integers: numba adds no negative-index wraparound code
for them (measured: a third of the decode time went to it).
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel, leading_zeros
from ..errors import FormatError
from .arith import NQ, SHARE
from .common import decoded_into, flat_view, wide
from .rangecoder import PROB_BITS, RATE, STATE_INIT
from .scan import N_CLASSES, Scan

CDF_BITS = 15
TOTAL = 1 << CDF_BITS
LOW = 1 << 16  # rANS states live in [LOW, 2^32) and start (and must end) at LOW
NS = 20  # bit-length symbols: 0..NS-2 direct, NS-1 escapes to n - (NS - 1) in 6 plain bits
ESC_BITS = 6
N_FLAG = N_CLASSES * NQ
N_MANT_CTX = 65 * N_CLASSES
MANT_BIN = N_FLAG  # binary models: the flags' first, then one per class for n == 2
N_BIN = N_FLAG + N_CLASSES
STEP = 16  # once warm, bit-length tables are rebuilt every STEP uses,
MSTEP = 8  # the mantissa tables every MSTEP
LIMIT = 1024  # counts halve when their total passes this
PRIOR = 4  # a fresh bit-length table counts 2^(PRIOR - |s - q|) for each s near q
RAW_PAD = 24  # zero bytes after the plain bits: one coefficient reads at most 9 past them


def row_width(ns):
    # counts f[0..ns-1], their total, the total at which the bounds are next rebuilt
    return ns + 2


def bound_words(ns):
    # bounds b[0..ns] (b[s] = scaled cumulative count + s, b[ns] = 2^15) as 16-bit lanes
    # of 64-bit words, padded with 2^15 (never below a slot)
    return (ns + 4) // 4


W = row_width(NS)
WM = row_width(4)
BW = bound_words(NS)
BWM = bound_words(4)
U = np.uint64  # unsigned indices: numba adds no negative-index wraparound for them
LANES = np.uint64(0x0001000100010001)
HIGH = np.uint64(0x8000800080008000)


def _pack(b, nwords):
    lanes = np.full(4 * nwords, 1 << CDF_BITS, dtype=np.uint64)
    lanes[: len(b)] = b
    return [int(sum(int(lanes[4 * w + k]) << (16 * k) for k in range(4))) for w in range(nwords)]


def _bounds(f, ns):
    """The bounds a table's counts give (as :func:`count_symbol` rebuilds them)."""
    tot = int(f.sum())
    scale = ((TOTAL - ns) << 16) // tot
    cum = np.concatenate([[0], np.cumsum(f)[:-1]])
    b = ((cum * scale) >> 16) + np.arange(ns)
    return np.concatenate([b, [TOTAL]])


def _initial_tables(nctx, ns, peak):
    t = np.zeros((nctx, row_width(ns)), dtype=np.int64)
    bw = bound_words(ns)
    packed = np.zeros((nctx, bw), dtype=np.uint64)
    for ctx in range(nctx):
        d = np.abs(np.arange(ns) - ctx % NQ)
        f = np.where(d <= PRIOR, 1 << np.maximum(PRIOR - d, 0), 0) if peak else np.ones(ns)
        f = f.astype(np.int64)
        t[ctx, :ns] = f
        t[ctx, ns] = f.sum()
        t[ctx, ns + 1] = f.sum() + 1  # the first use rebuilds
        packed[ctx] = _pack(_bounds(f, ns), bw)
    return t.reshape(-1).astype(np.int32), packed.reshape(-1)


CNT0, BND0 = _initial_tables(N_FLAG, NS, True)
MCNT0, MBND0 = _initial_tables(N_MANT_CTX, 4, False)


@kernel(inline=True)
def count_symbol(cnt, base, bnd, bb, ns, sym, step):
    """Count ``sym`` in the table at ``cnt[base:]``; when its total reaches the next
    rebuild, halve the counts if the total passed :data:`LIMIT` and rewrite the bounds at
    ``bnd[bb:]``: ``b[0] = 0``, ``b[j] = (C_j * scale >> 16) + j`` for ``0 < j < ns``
    (``C_j`` the counts below ``j``, ``scale = ((2^15 - ns) << 16) // total``), then
    ``2^15`` in every lane after. The next rebuild comes ``min(total, step)`` later."""
    cnt[U(base + sym)] += 1
    tot = cnt[U(base + ns)] + 1
    cnt[U(base + ns)] = tot
    if tot >= cnt[U(base + ns + 1)]:
        if tot > LIMIT:
            tot = 0
            for j in range(ns):
                f = (cnt[base + j] + 1) >> 1
                cnt[base + j] = f
                tot += f
            cnt[base + ns] = tot
        scale = (((1 << CDF_BITS) - ns) << 16) // tot
        cum = 0
        nw = (ns + 4) // 4
        for w in range(nw):
            word = np.uint64(0)
            for k in range(4):
                j = 4 * w + k
                if j == 0:
                    b = 0
                elif j < ns:
                    cum += cnt[base + j - 1]
                    b = ((cum * scale) >> 16) + j
                else:
                    b = 1 << CDF_BITS
                word |= np.uint64(b) << np.uint64(16 * k)
            bnd[bb + w] = word
        cnt[base + ns + 1] = tot + min(tot, step)


@kernel(inline=True)
def lane(bnd, bb, j):
    return np.int64((bnd[U(bb + (j >> 2))] >> np.uint64(16 * (j & 3))) & np.uint64(0xFFFF))


@kernel(inline=True)
def below(word, probe):
    """Per 16-bit lane: 1 where the lane's bound is <= the slot (``probe`` holds the slot
    in every lane with its top bit set, so no lane borrows from the next)."""
    return ((probe - word) & HIGH) >> np.uint64(15)


@kernel(inline=True)
def context(i, parent, cls, nbits, nprev, nbr):
    """:func:`.arith._context` in unsigned arithmetic (the same values, fewer steps)."""
    ui = U(i)
    p = parent[ui]
    npar = np.uint64(nbits[U(p)]) if p >= 0 else np.uint64(nprev)
    s = np.uint64(nprev)
    cnt = 1
    for a in range(3):
        j = nbr[ui, U(a)]
        if j >= 0 and j < i:
            s += np.uint64(nbits[U(j)])
            cnt += 1
    c = np.uint64(cnt)
    q = np.int64(
        ((npar * c + np.uint64(7) * s + np.uint64(4) * c) * np.uint64(SHARE[cnt])) // np.uint64(96)
    )
    q = min(q, NQ - 1)
    return np.int64(cls[ui]) * NQ + q, q


@kernel(inline=True)
def advance(words, x, pos, start, freq, slot):
    """The rANS decoder's step for a symbol of ``[start, start + freq)``, then refill."""
    x = freq * (x >> CDF_BITS) + slot - start
    # Branch-free refill (it is a coin toss to the branch predictor): ``words`` ends with
    # two zero words of padding, and a position past them only comes from damage.
    need = np.int64(x < LOW)
    w = np.int64(words[U(min(pos, words.size - 1))])
    sh = need << 4
    x = (x << sh) | (w & -need)
    pos += need
    return x, pos


@kernel(inline=True)
def get_sym(words, bnd, bb, nwords, x, pos):
    """Decode a symbol of the table whose bounds start at ``bnd[bb]``: count the bounds
    at or below the slot, four lanes at a time over ``nwords`` words."""
    slot = x & (TOTAL - 1)
    probe = np.uint64(slot) * LANES | HIGH
    s = below(bnd[U(bb)], probe)
    for w in range(1, nwords):
        s += below(bnd[U(bb + w)], probe)
    sym = np.int64((s * LANES) >> np.uint64(48)) - 1  # b[0] = 0 always counts
    start = lane(bnd, bb, sym)
    x, pos = advance(words, x, pos, start, lane(bnd, bb, sym + 1) - start, slot)
    return sym, x, pos


@kernel(inline=True)
def adapt_bin(models, k, p, u, mask):
    """:func:`.rangecoder.adapt` with unsigned indices (no wraparound code)."""
    r = RATE[U(u)]
    gain = ((1 << PROB_BITS) - p) >> r
    p += gain - ((gain + (p >> r)) & mask)
    models[U(k)] = (p << 4) | (u + (u < 15))


@kernel(inline=True)
def get_bin(words, models, k, x, pos):
    st = np.int64(models[U(k)])
    p = st >> 4
    u = st & 15
    f0 = p << (CDF_BITS - PROB_BITS)
    slot = x & (TOTAL - 1)
    bit = np.int64(slot >= f0)
    mask = -bit
    x, pos = advance(words, x, pos, f0 & mask, f0 + ((TOTAL - 2 * f0) & mask), slot)
    adapt_bin(models, k, p, u, mask)
    return bit, x, pos


@kernel(inline=True)
def put_bin(models, k, bit, starts, freqs, ns):
    st = np.int64(models[k])
    p = st >> 4
    u = st & 15
    f0 = p << (CDF_BITS - PROB_BITS)
    mask = -bit
    starts[ns] = f0 & mask
    freqs[ns] = f0 + ((TOTAL - 2 * f0) & mask)
    adapt_bin(models, k, p, u, mask)
    return ns + 1


@kernel(inline=True)
def put_sym(bnd, bb, sym, starts, freqs, ns):
    s = lane(bnd, bb, sym)
    starts[ns] = s
    freqs[ns] = lane(bnd, bb, sym + 1) - s
    return ns + 1


@kernel
def rans_encode(starts, freqs, nsym, words):
    """Code the recorded symbols last to first into the end of ``words`` (two states
    taking turns); returns the index of the first word, or -1 if ``words`` is short."""
    x0 = np.int64(LOW)
    x1 = np.int64(LOW)
    w = words.size
    for k in range(nsym - 1, -1, -1):
        if w < 8:
            return -1
        f = np.int64(freqs[k])
        x = x1 if k & 1 else x0
        if x >= (f << (32 - CDF_BITS)):
            w -= 1
            words[w] = x & 0xFFFF
            x >>= 16
        x = ((x // f) << CDF_BITS) + (x % f) + starts[k]
        if k & 1:
            x1 = x
        else:
            x0 = x
    w -= 4
    words[w] = x0 & 0xFFFF
    words[w + 1] = x0 >> 16
    words[w + 2] = x1 & 0xFFFF
    words[w + 3] = x1 >> 16
    return w


@kernel(inline=True)
def put_raw(raw, acc, cnt, rpos, v, n):
    """Append the n (<= 56) low bits of v to the plain bit stream, LSB first."""
    acc |= (v & ((np.uint64(1) << np.uint64(n)) - np.uint64(1))) << np.uint64(cnt)
    cnt += n
    while cnt >= 8:
        raw[rpos] = np.uint8(acc & np.uint64(0xFF))
        rpos += 1
        acc >>= np.uint64(8)
        cnt -= 8
    return acc, cnt, rpos


@kernel(inline=True)
def get_raw(raw, bitpos, n):
    """n (<= 48) bits at bitpos of the plain bit stream (``raw`` ends in RAW_PAD zeros)."""
    p = bitpos >> 3
    w = np.uint64(0)
    for k in range(8):
        w |= np.uint64(raw[U(p + k)]) << np.uint64(8 * k)
    w >>= np.uint64(bitpos & 7)
    return w & ((np.uint64(1) << np.uint64(n)) - np.uint64(1)), bitpos + n


@kernel(inline=True)
def put_low_bits(raw, acc, cnt, rpos, v, nb):
    """The ``nb - 3`` bits of ``v`` below its top three as plain bits (two groups when
    more than 48: the top ``nb - 27``, then the low 24)."""
    r = nb - 3
    if r > 48:
        acc, cnt, rpos = put_raw(raw, acc, cnt, rpos, v >> np.uint64(24), r - 24)
        r = 24
    return put_raw(raw, acc, cnt, rpos, v, r)


@kernel(inline=True)
def get_low_bits(raw, bitpos, v, nb):
    """:func:`put_low_bits`' bits appended below ``v`` (the top three bits of a value
    of ``nb`` bits)."""
    r = nb - 3
    if r > 48:
        d, bitpos = get_raw(raw, bitpos, r - 24)
        v = (v << np.uint64(r - 24)) | d
        r = 24
    d, bitpos = get_raw(raw, bitpos, r)
    return (v << np.uint64(r)) | d, bitpos


@kernel(inline=True)
def raw_end_status(raw, bitpos):
    """0 when the plain bits end at ``bitpos`` in the last byte (``raw`` ends in
    RAW_PAD zeros) with zero padding bits, 1 when they ran short, else 3."""
    if bitpos > (raw.size - RAW_PAD) * 8:
        return 1
    if (bitpos + 7) >> 3 != raw.size - RAW_PAD or (bitpos & 7 and raw[bitpos >> 3] >> (bitpos & 7)):
        return 3  # plain bits left over, or padding bits that are not zero
    return 0


@kernel(inline=True)
def gather(flat, perm):
    """The coefficients in scan order and the count of non-zeros before each position
    (a subtree ``[i, e)`` is all zero when the counts at ``i`` and ``e`` agree)."""
    n = perm.size
    vals = np.empty(n, dtype=np.int64)
    nz = np.zeros(n + 1, dtype=np.int32)
    for i in range(n):
        c = np.int64(flat[perm[i]])
        vals[i] = c
        nz[i + 1] = nz[i] + (c != 0)
    return vals, nz


@kernel
def _model_kernel(flat, perm, end, parent, cls, nbr, starts, freqs, raw, cnt0, bnd0, mcnt0, mbnd0):
    """The encoder's pass: run the models forward and record each symbol's interval
    (coded afterwards by :func:`rans_encode`), plain bits into ``raw``; returns (symbols,
    raw bytes), or (-1, 0) when a buffer is short."""
    n = perm.size
    vals, nz = gather(flat, perm)
    models = np.full(N_BIN, STATE_INIT, dtype=np.uint16)
    cnt = cnt0.copy()
    bnd = bnd0.copy()
    mcnt = mcnt0.copy()
    mbnd = mbnd0.copy()
    nbits = np.zeros(n, dtype=np.uint8)
    acc = np.uint64(0)
    nacc = 0
    rpos = 0
    ns = 0
    nprev = 0
    i = 0
    while i < n:
        if ns + 4 > starts.size or rpos + 32 > raw.size:
            return -1, 0
        ctx, q = context(i, parent, cls, nbits, nprev, nbr)
        e = end[i]
        if e > i + 1:
            bit = np.int64(nz[e] != nz[i])
            ns = put_bin(models, ctx, bit, starts, freqs, ns)
            if bit == 0:
                nprev = 0
                i = e
                continue
        c = vals[i]
        v = np.uint64((c << 1) ^ (c >> 63))
        nb = 64 - np.int64(leading_zeros(v))
        sym = min(nb, NS - 1)
        base = ctx * W
        ns = put_sym(bnd, ctx * BW, sym, starts, freqs, ns)
        count_symbol(cnt, base, bnd, ctx * BW, NS, sym, STEP)
        if sym == NS - 1:
            acc, nacc, rpos = put_raw(raw, acc, nacc, rpos, np.uint64(nb - sym), ESC_BITS)
        if nb == 2:
            ns = put_bin(models, MANT_BIN + cls[i], np.int64(v & np.uint64(1)), starts, freqs, ns)
        elif nb >= 3:
            m = np.int64(v >> np.uint64(nb - 3)) & 3
            mc = nb * N_CLASSES + cls[i]
            ns = put_sym(mbnd, mc * BWM, m, starts, freqs, ns)
            count_symbol(mcnt, mc * WM, mbnd, mc * BWM, 4, m, MSTEP)
            acc, nacc, rpos = put_low_bits(raw, acc, nacc, rpos, v, nb)
        nbits[i] = nb
        nprev = nb
        i += 1
    if nacc > 0:
        raw[rpos] = np.uint8(acc & np.uint64(0xFF))
        rpos += 1
    return ns, rpos


@kernel(nrt=False)
def _decode_kernel(
    words, raw, perm, end, parent, cls, nbr, flat, nmax, models, cnt, bnd, mcnt, mbnd, nbits
):
    n = perm.size
    nw = words.size - 2  # the stream's words, then two of padding
    if nw < 4:
        return 1
    x = np.int64(words[0]) | (np.int64(words[1]) << 16)
    y = np.int64(words[2]) | (np.int64(words[3]) << 16)
    pos = 4
    bitpos = 0
    rawbits = (raw.size - RAW_PAD) * 8
    nprev = 0
    i = 0
    while i < n:
        if pos > nw or bitpos > rawbits:
            return 1
        ctx, q = context(i, parent, cls, nbits, nprev, nbr)
        e = end[U(i)]
        if e > i + 1:
            bit, x, pos = get_bin(words, models, ctx, x, pos)
            x, y = y, x
            if bit == 0:  # the caller zeroed ``flat``
                nprev = 0
                i = e
                continue
        base = ctx * W
        sym, x, pos = get_sym(words, bnd, ctx * BW, BW, x, pos)
        x, y = y, x
        count_symbol(cnt, base, bnd, ctx * BW, NS, sym, STEP)
        nb = sym
        if sym == NS - 1:
            d, bitpos = get_raw(raw, bitpos, ESC_BITS)
            nb += np.int64(d)
            if nb > nmax:
                return 2
        if nb >= 3:
            mc = nb * N_CLASSES + cls[U(i)]
            m, x, pos = get_sym(words, mbnd, mc * BWM, 1, x, pos)  # b[0..3] in one word
            x, y = y, x
            count_symbol(mcnt, mc * WM, mbnd, mc * BWM, 4, m, MSTEP)
            v, bitpos = get_low_bits(raw, bitpos, np.uint64(4 | m), nb)
        elif nb == 2:
            bit, x, pos = get_bin(words, models, MANT_BIN + cls[U(i)], x, pos)
            x, y = y, x
            v = np.uint64(2 | bit)
        else:
            v = np.uint64(nb)
        flat[U(perm[U(i)])] = np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))
        nbits[U(i)] = nb
        nprev = nb
        i += 1
    status = raw_end_status(raw, bitpos)
    if status:
        return status
    if pos != nw or x != LOW or y != LOW:
        return 3 if pos <= nw else 1
    return 0


def encode(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Code a coefficient array (int32 or int64) in ``scan`` order."""
    flat = wide(flat_view(coeffs))
    starts = np.empty(3 * flat.size + 8, dtype=np.int32)
    freqs = np.empty(3 * flat.size + 8, dtype=np.int32)
    raw = np.empty(9 * flat.size + 64, dtype=np.uint8)  # at most 67 plain bits each
    nsym, nraw = _model_kernel(
        flat,
        scan.perm,
        scan.end,
        scan.parent,
        scan.cls,
        scan.nbr,
        starts,
        freqs,
        raw,
        CNT0,
        BND0,
        MCNT0,
        MBND0,
    )
    if nsym < 0:
        raise AssertionError("coefficient coder overflowed its worst-case buffer")
    words = np.empty(nsym + 8, dtype=np.uint16)  # at most one word out per symbol
    w = rans_encode(starts, freqs, nsym, words)
    body = words[w:].astype("<u2").tobytes()
    return (len(body) // 2).to_bytes(4, "little") + body + raw[:nraw].tobytes()


def decode(data: bytes, scan: Scan, out: np.ndarray) -> None:
    """Decode ``data`` into ``out`` (a C-contiguous int32/int64 array, overwritten)."""
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    buf = np.frombuffer(data, dtype=np.uint8)
    if buf.size < 4:
        raise FormatError("corrupt arith2-coded brick: no word count")
    nw = int.from_bytes(bytes(buf[:4]), "little")
    k = 4
    used = 2 * nw
    if k + used > buf.size:
        raise FormatError("corrupt arith2-coded brick: the word count runs past the payload")
    rc = np.zeros(used // 2 + 2, dtype=np.uint16)
    rc[: used // 2] = buf[k : k + used].view("<u2")
    raw = np.zeros(buf.size - k - used + RAW_PAD, dtype=np.uint8)
    raw[: buf.size - k - used] = buf[k + used :]
    models = np.full(N_BIN, STATE_INIT, dtype=np.uint16)
    nbits = np.zeros(flat.size, dtype=np.uint8)
    decoded_into(
        flat,
        lambda into, nmax: _decode_kernel(
            rc, raw, scan.perm, scan.end, scan.parent, scan.cls, scan.nbr, into, nmax,
            models, CNT0.copy(), BND0.copy(), MCNT0.copy(), MBND0.copy(), nbits,
        ),
        "arith2",
        zeroed=True,  # zero subtrees are skipped, not written
    )  # fmt: skip
