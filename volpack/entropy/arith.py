"""Significance map + adaptive binary arithmetic coding (the best-ratio coder).

Coefficients are visited in the scan order of :mod:`volpack.wavelet.sigmap` and mapped to
unsigned integers ``m`` (``c >= 0 -> 2c``, ``c < 0 -> -2c - 1``). For each position:

1. If the position roots a subtree (dfs scan), one binary flag says whether the whole
   subtree is zero; if so it is skipped. These flags are the significance map.
2. The bit length ``n`` of ``m`` (0 for a zero) is coded as a count up or down from an
   estimate ``q`` made from the parent and the two previously coded coefficients, each
   step a binary decision with its own adaptive probability in the context (subband
   class, ``q``): about three decisions for a typical coefficient.
3. The two bits below the leading one are coded with adaptive probabilities per
   ``(n, bits so far, class)``: within one bit length, small values are likelier. The
   remaining low bits (the sign in the last place) are coded at probability one half.

The arithmetic coder is a binary range coder with 12-bit probabilities, a 32-bit range
and byte-wise carry propagation: one multiply per decision and no division. Each
probability adapts fast while young and settles as it is used. The stream layout is given
in ``formats/wavelet-1.md``.
"""

from __future__ import annotations

import collections
import threading
import weakref

import numpy as np

from .._jit import kernel, leading_zeros
from ..errors import FormatError
from .common import decoded_into, encode_with_retry, flat_view, wide
from .rangecoder import (
    RATE,
    STATE_INIT,
    end_status,
    finish_stream,
    get,
    get_bits,
    open_encoder,
    open_stream,
    put,
    put_bits,
)
from .scan import N_CLASSES, Scan

TREE_BITS = 6  # 2**6 models per context for the bit length
NQ = 12  # quantised local-magnitude contexts
SHARE = np.array([0, 12, 6, 4, 3], dtype=np.int64)  # 96 / (8 c)
MANT_BITS = 2  # bits below the leading one that get adaptive probabilities
N_FLAG = N_CLASSES * NQ
N_TREE = N_FLAG << TREE_BITS
N_MODELS = N_FLAG + N_TREE + ((64 << MANT_BITS) * N_CLASSES)


# Array indices known to be >= 0 are cast to unsigned (_U): numba tests every signed
# index for a negative wrap-around, a compare and a select per access (5-10 % of the
# decoder's time).
_U = np.uint64


@kernel(inline=True)
def _context(i, parent, cls, nbits, nprev, nbr):
    p = parent[_U(i)]
    npar = np.int64(nbits[_U(p)]) if p >= 0 else nprev
    s = nprev
    cnt = 1
    for a in range(3):
        j = nbr[_U(i), _U(a)]
        if j >= 0 and j < i:
            s += np.int64(nbits[_U(j)])
            cnt += 1
    # (npar c + 7 s + 4 c) // (8 c) for c in 1..4, as one multiply: 8c divides 96.
    q = ((npar * cnt + 7 * s + 4 * cnt) * SHARE[_U(cnt)]) // 96
    if q >= NQ:
        q = NQ - 1
    return np.int64(cls[_U(i)]) * NQ + q, q


@kernel(inline=True)
def _mant_model(nb, prefix, c):
    return N_FLAG + N_TREE + ((nb << MANT_BITS) + prefix) * N_CLASSES + c


# The bit coding below is written out in place rather than called: numba's inlining of
# a helper that returns the coder state as a tuple (or keeps it in an array) ran these
# loops at half to a third of the speed. Bits are coded without branches on their value,
# which the branch predictor cannot guess.


@kernel
def _encode_kernel(flat, perm, end, parent, cls, nbr, out):
    n = perm.size
    vals = np.empty(n, dtype=np.int64)  # coefficients in scan order, gathered once
    nz = np.zeros(n + 1, dtype=np.int32)  # non-zeros before each scan position
    for i in range(n):
        c = np.int64(flat[perm[i]])
        vals[i] = c
        nz[i + 1] = nz[i] + (c != 0)
    state = np.full(N_MODELS, STATE_INIT, dtype=np.uint16)
    nbits = np.zeros(n, dtype=np.uint8)  # bit length at each scan position
    cap = out.size
    low, rng, pos = open_encoder(out)  # 32-bit low; a carry is added to the bytes out
    nprev = 0
    i = 0
    while i < n:
        if pos + 32 > cap:
            return -1
        ctx, q = _context(i, parent, cls, nbits, nprev, nbr)
        e = end[i]
        if e > i + 1:  # the subtree flag
            bit = np.int64(nz[e] != nz[i])
            k = ctx
            low, rng, pos = put(out, state, k, bit, low, rng, pos, RATE)
            if bit == 0:
                nprev = 0
                i = e
                continue
        c = vals[i]
        v = np.uint64((c << 1) ^ (c >> 63))
        nb = 64 - np.int64(leading_zeros(v))
        base = N_FLAG + (ctx << TREE_BITS)
        up = nb >= q
        bit = np.int64(up)
        k = base
        low, rng, pos = put(out, state, k, bit, low, rng, pos, RATE)
        j = q if up else q - 1
        while (up and j < 63) or (not up and j > 0):  # count from the estimate q
            k = base + 1 + min(j - q, 46) if up else base + 48 + (q - 1 - j)
            bit = np.int64(nb > j) if up else np.int64(nb < j)
            low, rng, pos = put(out, state, k, bit, low, rng, pos, RATE)
            if nb == j:
                break
            j += 1 if up else -1
        nm = min(nb - 1, MANT_BITS)
        if nm > 0:
            top = np.int64(v >> np.uint64(nb - 1 - nm))  # the leading one and nm bits
            for jm in range(nm):
                k = _mant_model(nb, top >> (nm - jm), cls[i])
                bit = (top >> (nm - 1 - jm)) & 1
                low, rng, pos = put(out, state, k, bit, low, rng, pos, RATE)
        # The low bits at one half.
        low, rng, pos = put_bits(out, v, nb - 1 - max(nm, 0), low, rng, pos)
        nbits[i] = nb
        nprev = nb
        i += 1
    return finish_stream(out, low, pos)


@kernel
def decode_kernel(data, perm, end, parent, cls, nbr, flat, nmax):
    """Return 0 on success, 1 when the stream ran short, 2 on an impossible symbol, 3 when
    it does not end where its length says."""
    n = perm.size
    size = data.size
    state = np.full(N_MODELS, STATE_INIT, dtype=np.uint16)
    nbits = np.zeros(n, dtype=np.uint8)  # bit length at each scan position
    code, rng, pos = open_stream(data)
    nprev = 0
    i = 0
    while i < n:
        if pos > size + 4:
            return 1
        ctx, q = _context(i, parent, cls, nbits, nprev, nbr)
        e = np.int64(end[_U(i)])
        if e > i + 1:  # the subtree flag
            k = ctx
            bit, code, rng, pos = get(data, state, k, code, rng, pos, RATE)
            if bit == 0:  # the caller zeroed ``flat``
                nprev = 0
                i = e
                continue
        base = N_FLAG + (ctx << TREE_BITS)
        k = base
        bit, code, rng, pos = get(data, state, k, code, rng, pos, RATE)
        up = bit == 1
        nb = q if up else q - 1
        while (up and nb < 63) or (not up and nb > 0):  # count from the estimate q
            k = base + 1 + min(nb - q, 46) if up else base + 48 + (q - 1 - nb)
            bit, code, rng, pos = get(data, state, k, code, rng, pos, RATE)
            if bit == 0:
                break
            nb += 1 if up else -1
        if nb > nmax:
            return 2
        v = np.uint64(1 if nb >= 1 else 0)
        prefix = 1
        c = cls[_U(i)]
        for _ in range(min(nb - 1, MANT_BITS)):
            k = _mant_model(nb, prefix, c)
            bit, code, rng, pos = get(data, state, k, code, rng, pos, RATE)
            prefix = 2 * prefix + bit
            v = (v << np.uint64(1)) | np.uint64(bit)
        v, code, rng, pos = get_bits(data, v, nb - 1 - min(nb - 1, MANT_BITS), code, rng, pos)
        flat[_U(perm[_U(i)])] = np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))
        nbits[_U(i)] = nb
        nprev = nb
        i += 1
    return end_status(data, code, pos)


def context_table(scan: Scan) -> np.ndarray:
    """What :func:`decode_tabled_kernel` reads per scan position, made once a scan: int32
    rows of the three neighbours :func:`_context` sums (``n``, whose bit length stays 0,
    where a neighbour is missing or comes later), 1 + the count of those present and the
    parent (``n`` for a root). It depends on ``nbr`` and ``parent`` alone, which the
    ``line`` and ``rows`` scans of a shape share."""
    t = np.empty((scan.perm.size, 5), np.int32)
    _context_table_kernel(scan.nbr, scan.parent, t)
    return t


@kernel
def _context_table_kernel(nbr, parent, t):
    # one pass (numpy took a dozen calls over the scan, 0.9 ms a 32^3 brick)
    n = t.shape[0]
    for i in range(n):
        cnt = 1
        for a in range(3):
            v = nbr[i, a]
            if 0 <= v < i:
                t[i, a] = v
                cnt += 1
            else:
                t[i, a] = n
        t[i, 3] = cnt
        t[i, 4] = parent[i] if parent[i] >= 0 else n


# The tables :func:`decode` made, by the identity of the scan arrays they come from (held
# weakly: a table goes when its scan's arrays do, or when the tables together pass
# TABLE_CACHE_BYTES, least recently used first). The table is a pass over every
# coefficient, where the decoder skips zero subtrees: made per decode it cost the float
# wavelet bricks at loose bounds 5-15 % (ldec31); the scans it comes from are cached.
TABLE_CACHE_BYTES = 48 << 20  # 20 bytes a coefficient: a 128^3 brick's table, 42 MB
TABLE_CACHE_ENTRIES = 256  # with the scans only noted (no table yet), which cost no bytes
# Under this many payload bits a coefficient a first decode costs more with the table's
# pass than without (tab31, decodes of one brick with the cache emptied: 0.18-0.39 bits
# 0.92-0.97x, 0.83-8.3 bits 1.08-1.11x); such a scan gets its table when decoded again.
TABLE_BITS_A_COEFFICIENT = 0.5
_tables: collections.OrderedDict = collections.OrderedDict()  # ids -> (weakrefs, table)
_tables_lock = threading.Lock()


def cached_context_table(scan: Scan, build: bool = True) -> np.ndarray | None:
    """:func:`context_table` of ``scan``, kept for the next decode of the same scan; with
    ``build`` false and none kept, ``None`` (the scan noted: its next call builds it)."""
    key = (id(scan.nbr), id(scan.parent))
    with _tables_lock:
        hit = _tables.get(key)
        if hit is not None and hit[0][0]() is scan.nbr and hit[0][1]() is scan.parent:
            _tables.move_to_end(key)
            if hit[1] is not None:
                return hit[1]
            build = True  # asked for before
        elif not build:
            _keep(key, scan, None)
            return None
    t = context_table(scan)
    t.flags.writeable = False
    with _tables_lock:
        _keep(key, scan, t)
    return t


def _keep(key, scan: Scan, t: np.ndarray | None) -> None:
    """Hold ``t`` (or note ``scan``) as the newest, within the bounds (the lock held)."""
    _tables[key] = ((weakref.ref(scan.nbr), weakref.ref(scan.parent)), t)
    _tables.move_to_end(key)
    total = sum(v[1].nbytes for v in _tables.values() if v[1] is not None)
    while len(_tables) > 1 and (total > TABLE_CACHE_BYTES or len(_tables) > TABLE_CACHE_ENTRIES):
        old = _tables.popitem(last=False)[1][1]  # the newest kept, whatever its size
        total -= 0 if old is None else old.nbytes


def clear_tables() -> None:
    """Let every cached context table go."""
    with _tables_lock:
        _tables.clear()


@kernel(inline=True)
def _tabled_context(row, nbits, nprev, n):
    """:func:`_context` from a :func:`context_table` row: no test a neighbour, one
    select for the parent. (A damaged stream can decode a bit length of -1, which makes
    the estimate negative: kept signed, as :func:`_context` has it.)"""
    p = row[4]
    npar = np.int64(nbits[_U(p)]) if p < n else nprev
    s = nprev + (np.int64(nbits[_U(row[0])]) + np.int64(nbits[_U(row[1])])
                 + np.int64(nbits[_U(row[2])]))  # fmt: skip
    cnt = np.int64(row[3])
    x = (npar * cnt + 7 * s + 4 * cnt) * SHARE[_U(cnt)]
    if x < 0:  # damage only: floor division, as _context's
        return x // 96
    return np.int64(min(np.uint64(x) // np.uint64(96), np.uint64(NQ - 1)))


@kernel
def decode_tabled_kernel(data, perm, end, ctab, cls, flat, nmax):
    """:func:`decode_kernel` with its contexts' fixed parts read from ``ctab``
    (:func:`context_table` of the scan ``perm`` and ``end`` come from) and the bit
    length's count up and down as two loops: the same decisions in the same models, so
    the same coefficients and statuses, on a sixth less CPU (README, walk16)."""
    n = perm.size
    size = data.size
    state = np.full(N_MODELS, STATE_INIT, dtype=np.uint16)
    nbits = np.zeros(n + 1, dtype=np.uint8)  # nbits[n] stays 0: "no neighbour"
    code, rng, pos = open_stream(data)
    nprev = 0
    i = 0
    while i < n:
        if pos > size + 4:
            return 1
        row = ctab[_U(i)]
        q = _tabled_context(row, nbits, nprev, n)
        c = np.int64(cls[_U(i)])
        ctx = c * NQ + q
        e = np.int64(end[_U(i)])
        if e > i + 1:  # the subtree flag (model -1, from damage, is the last one)
            kf = _U(ctx) if ctx >= 0 else _U(ctx + N_MODELS)
            bit, code, rng, pos = get(data, state, kf, code, rng, pos, RATE)
            if bit == 0:  # the caller zeroed ``flat``
                nprev = 0
                i = e
                continue
        base = N_FLAG + (ctx << TREE_BITS)
        bit, code, rng, pos = get(data, state, _U(base), code, rng, pos, RATE)
        if bit == 1:  # count up from the estimate q
            nb = q
            while nb < 63:
                bit, code, rng, pos = get(data, state, _U(base + 1 + min(nb - q, 46)), code, rng,
                                          pos, RATE)  # fmt: skip
                if bit == 0:
                    break
                nb += 1
        else:  # or down
            nb = q - 1
            while nb > 0:
                bit, code, rng, pos = get(data, state, _U(base + 48 + (q - 1 - nb)), code, rng,
                                          pos, RATE)  # fmt: skip
                if bit == 0:
                    break
                nb -= 1
        if nb > nmax:
            return 2
        # the rest as decode_kernel's, written out again: a helper returning the coder's
        # state ran these loops at half the speed (the note above _encode_kernel)
        v = np.uint64(1 if nb >= 1 else 0)
        prefix = 1
        for _ in range(min(nb - 1, MANT_BITS)):
            k = _U(_mant_model(nb, prefix, c))
            bit, code, rng, pos = get(data, state, k, code, rng, pos, RATE)
            prefix = 2 * prefix + bit
            v = (v << np.uint64(1)) | np.uint64(bit)
        v, code, rng, pos = get_bits(data, v, nb - 1 - min(nb - 1, MANT_BITS), code, rng, pos)
        flat[_U(perm[_U(i)])] = np.int64(v >> np.uint64(1)) ^ -(np.int64(v & np.uint64(1)))
        nbits[_U(i)] = nb
        nprev = nb
        i += 1
    return end_status(data, code, pos)


def encode(coeffs: np.ndarray, scan: Scan) -> bytes:
    """Code a coefficient array (int32 or int64) in ``scan`` order."""
    flat = wide(flat_view(coeffs))
    return encode_with_retry(
        lambda out: _encode_kernel(flat, scan.perm, scan.end, scan.parent, scan.cls, scan.nbr, out),
        flat.size,
    )


def decode(data: bytes, scan: Scan, out: np.ndarray) -> None:
    """Decode ``data`` into ``out`` (a C-contiguous int32/int64 array, overwritten)."""
    flat = flat_view(out)
    if flat.size != scan.perm.size:
        raise FormatError(f"expected {scan.perm.size} coefficients, found room for {flat.size}")
    buf = np.frombuffer(data, dtype=np.uint8)
    # the tabled decoder (the same decisions, coefficients and statuses), its table
    # cached: 8-15 % less than decode_kernel's time on 0.1-2 M coefficients (ldec31)
    ctab = cached_context_table(scan, 8 * buf.size >= TABLE_BITS_A_COEFFICIENT * flat.size)
    if ctab is None:  # a sparse payload of a scan not seen before

        def run(into, nmax):
            return decode_kernel(
                buf, scan.perm, scan.end, scan.parent, scan.cls, scan.nbr, into, nmax
            )
    else:

        def run(into, nmax):
            return decode_tabled_kernel(buf, scan.perm, scan.end, ctab, scan.cls, into, nmax)

    decoded_into(
        flat,
        run,
        "arithmetic",
        zeroed=True,  # zero subtrees are skipped, not written (one memset, not a scatter)
    )
