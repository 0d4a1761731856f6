"""Fast predictive coding of integer voxels: one cheap prediction and one rANS symbol a voxel.

The ``predict`` tool of the lossless codec (:mod:`.predict`) blends six predictors and
codes about seven adaptive binary decisions a voxel: the best ratio, at a fraction of
JPEG-LS's decode speed. This coder keeps what buys most of the ratio and drops what
costs the time:

* prediction: the median edge detector of LOCO-I (``MED``: ``W + N - NW`` clamped
  between ``W`` and ``N``) in the voxel's slice, or that plus the same predictor's
  error at the voxel above (``U - MED(UW, UN, UNW)``), or the mean of the two; the
  encoder measures the three on the brick and keeps the cheapest (a slice-to-slice
  correlation pays in MRIs, not in thick-sliced CT);
* residuals zig-zagged to ``u >= 0`` and cut into a token and raw low bits: ``u < 16``
  is its own token, a larger ``u`` of bit length ``n`` is token
  ``16 + 4 (n - 5) + (its two bits below the leading one)`` and its ``n - 3`` low bits
  go raw to a separate bit stream (16-bit data keeps a small alphabet);
* tokens coded by static rANS (:mod:`volpack.entropy.rans`) with per-brick frequency
  tables, one per context: the activity ``a`` of the residuals already decoded next to
  the voxel (``u_W + u_N``, or ``u_W + u_N + u_U`` / ``u_N + u_NE + u_U``, the encoder
  picks), on a log scale with two classes an octave;
* two rANS states taking symbols in turn, so the two decode chains overlap on one core;
* a run mode (bit 7 of the choice byte): where the activity is 0, the number of the
  following voxels whose residual is 0 is one symbol, and the decoder fills them a row
  segment at a time (a plain fill where the row above is flat), as JPEG-LS's run mode
  but across rows and slices and for any predicted value, not only W's.

The byte layout is in ``formats/fast-1.md``.
"""

from __future__ import annotations

import math
import threading

import numpy as np

from .._jit import kernel, leading_zeros, read_only
from ..entropy import rans
from ..errors import FormatError, OptionError
from . import palette as pal
from .predict import checked_input

PREDICTORS = ("med", "med3d", "mean")
CONTEXTS = ("near", "far")  # the activity with W (better ratio) or without (faster)
NPRED, NCTXR = len(PREDICTORS), len(CONTEXTS)
DIRECT = 16  # tokens 0..15 are the zig-zagged residual itself
NTOK = DIRECT + 4 * 29  # bit lengths up to 33: residuals of a span below 2^32
NCLASS = 48  # activity classes before the encoder caps them
STATES = 2
RUN_LENGTH, RUN_BREAK = NCLASS, NCLASS + 1  # the encoder's contexts of the run mode
RUNS = 0x80  # bit 7 of the choice byte: the stream has the run mode
ROWS = 0x40  # bit 6: a row may start a run of rows that copy the row above or the slice
# above (in the coded bricks of the atlases, liver and frog 67-91 % of the rows are)
ROW_KIND = NCLASS + 2  # the encoder's contexts of the row kinds, by the previous row's kind,
ROW_COUNT = ROW_KIND + 3  # then of the copy runs' lengths, by kind (N, U)
ROW_TABLES = 5
RUN_SLACK = 0.4  # the run mode may cost this share of bytes times the square of the share
# of voxels in runs (a brick all in runs decodes 3-8x faster; one with few gains little),
RUN_BITS = 0.01  # or this many bits a voxel times that square (label bricks of a few
# hundred bytes, where a relative slack is no slack)
NS_BITS = 0.016  # a faster stream may also spend this many bits a nanosecond of decode it
# saves (by :func:`decode_ns`; 2 KB a millisecond): on label bricks of a few hundred bytes
# the run rule's allowance is a few dozen bytes, and the plain stream decodes 10-30x slower
BAD_SYMBOL = 0xFF  # what the slots of an unused context decode to
NEAR_GAIN = 0.01  # the share of bytes the slower ``near`` context must save
ONE, TWO, THREE = np.uintp(1), np.uintp(2), np.uintp(3)  # unsigned offsets: no wrap test
STATUS = {
    1: "the stream ends before the last voxel",
    2: "a token decodes to a value outside the brick's range",
    3: "it does not end where its lengths say",
    4: "a run runs past the brick's end",
    5: "a run of copied rows does not fit the brick",
}


def _token_tables() -> tuple[np.ndarray, np.ndarray]:
    """Each token's base value and raw bit count (a token that no residual makes gets a
    base no value range reaches, so decoding it fails the range check)."""
    base = np.full(rans.MAX_SYMBOLS, 1 << 40, dtype=np.int64)
    nbits = np.zeros(rans.MAX_SYMBOLS, dtype=np.int64)
    base[:DIRECT] = np.arange(DIRECT)
    for t in range(DIRECT, NTOK):
        n = (t - DIRECT) // 4 + 5
        base[t] = (4 | ((t - DIRECT) & 3)) << (n - 3)
        nbits[t] = n - 3
    return base, nbits


TOK_BASE, TOK_BITS = _token_tables()
TOK = (TOK_BASE << 6) | TOK_BITS  # the decoder's one look-up a token: base, raw bit count
UCAP = 1 << 24  # the decoder keeps residuals capped here for the contexts: a sum with one
# term this large has the last class (47) whether it is capped or not


@kernel(inline=True)
def _bitlen(u):
    return 64 - np.int64(leading_zeros(np.uint64(u)))


@kernel(inline=True)
def _activity(a):
    """Log class of a non-negative activity: 0..3 exactly, then two classes an octave,
    below ``NCLASS``."""
    b = _bitlen(a | 4)
    c = min(2 * b - 2 + ((a >> (b - 2)) & 1), NCLASS - 1)
    return a if a < 4 else c


def _activity_table(n: int) -> np.ndarray:
    """:func:`_activity` of ``0..n-1`` (uint8): the decoder's look-up below ``n``."""
    a = np.arange(n)
    b = np.array([int(x | 4).bit_length() for x in a])
    c = np.minimum(2 * b - 2 + ((a >> (b - 2)) & 1), NCLASS - 1)
    return np.where(a < 4, a, c).astype(np.uint8)


ACTIVITY = _activity_table(4096)  # capped at a brick's last context by :func:`_head_kernel`


@kernel(inline=True)
def _token(u):
    """``(token, raw bit count)`` of a zig-zagged residual."""
    n = _bitlen(u)
    if u < DIRECT:
        return u, np.int64(0)
    return DIRECT + 4 * (n - 5) + ((u >> (n - 3)) & 3), n - 3


@kernel(inline=True)
def _med(a, b, c):
    """LOCO-I's median edge detector: ``a + b - c`` clamped between ``a`` and ``b``."""
    return min(max(a + b - c, min(a, b)), max(a, b))


@kernel(inline=True)
def _correct(p, d, pid):
    """A 2-D prediction plus the 3-D correction ``d`` (the same predictor's error one
    slice up): whole for ``med3d``, half (floored) for ``mean``, none for ``med``."""
    if pid == 1:
        return p + d
    if pid == 2:
        return p + (d >> 1)
    return p


@kernel(inline=True)
def _predict(v, i, z, y, x, sy, sz, pid, mid):
    """The prediction of voxel ``i`` = (z, y, x) from decoded voxels, before clipping:
    MED inside the slice, the one neighbour there on its first row and column, U for
    its first voxel; plus the 3-D correction from the slice above (``pid`` 1, 2)."""
    j = i - sz
    if x > 0 and y > 0:
        p = _med(np.int64(v[i - 1]), np.int64(v[i - sy]), np.int64(v[i - sy - 1]))
        if z > 0 and pid != 0:
            p = _correct(p, v[j] - _med(np.int64(v[j - 1]), v[j - sy], v[j - sy - 1]), pid)
        return p
    if x == 0 and y == 0:
        return np.int64(v[j]) if z > 0 else np.int64(mid)
    k = 1 if x > 0 else sy
    p = np.int64(v[i - k])
    if z > 0 and pid != 0:
        p = _correct(p, np.int64(v[j]) - v[j - k], pid)
    return p


@kernel(inline=True)
def _context(v, u, i, r, ru, z, y, x, nx, cid):
    """Activity class of voxel ``i`` (ring slot ``r``; ``ru`` the slot of U): the
    zig-zagged residuals ``u`` of W (context ``near`` only), N, NW, NE and U, plus twice
    the gradients ``|N - NW| + |NE - N|`` (and ``|W - NW|``, ``near``), each term where
    its neighbours exist."""
    a = np.int64(0)
    g = np.int64(0)
    if y > 0:
        n = np.int64(v[i - nx])
        a += u[r - nx]
        if x > 0:
            a += u[r - nx - 1]
            g += abs(n - v[i - nx - 1])
            if cid == 0:
                g += abs(np.int64(v[i - 1]) - v[i - nx - 1])
        if x + 1 < nx:
            a += u[r - nx + 1]
            g += abs(np.int64(v[i - nx + 1]) - n)
    if x > 0 and cid == 0:
        a += u[r - 1]
    if z > 0:
        a += u[ru]
    return _activity(a + 2 * g)


@kernel(inline=True)
def _put_bits(bits, bpos, acc, nacc, value, nb):
    """Append the ``nb`` low bits of ``value`` to the raw bit stream ``(bits, bpos, acc,
    nacc)`` (LSB first); ``bpos`` -1 when ``bits`` is too small."""
    if bpos + 16 > bits.size:
        return np.int64(-1), acc, nacc
    acc |= np.uint64(value & ((1 << nb) - 1)) << np.uint64(nacc)
    nacc += nb
    while nacc >= 8:
        bits[bpos] = np.uint8(acc & np.uint64(0xFF))
        acc >>= np.uint64(8)
        nacc -= 8
        bpos += 1
    return bpos, acc, nacc


@kernel(inline=True)
def emit(toks, ctxs, counts, k, c, value, bits, bpos, acc, nacc):
    """Symbol ``k``: the token of ``value`` in context ``c``, its raw bits appended."""
    t, nb = _token(value)
    toks[k] = t
    ctxs[k] = c
    counts[c, t] += 1
    if nb > 0:
        return _put_bits(bits, bpos, acc, nacc, value, nb)
    return bpos, acc, nacc


@kernel(inline=True)
def _same_row(v, i, back, nx):
    """Whether the row from voxel ``i`` repeats the one ``back`` voxels before."""
    for x in range(nx):
        if v[i + x] != v[i - back + x]:
            return False
    return True


@kernel(inline=True)
def _row_run(v, i, nx, ny, nz, y, z):
    """``(kind, count)`` of the row from voxel ``i`` = (z, y, 0): kind 1 when it copies
    the row above (N), else 2 when it copies the same row of the slice above (U), else
    0; for 1 and 2, how many of the rows after it (in the slice for N, up to the
    brick's end for U) copy the same way."""
    sy, sz = nx, ny * nx
    if y > 0 and _same_row(v, i, sy, nx):
        c = 0
        while y + c + 1 < ny and _same_row(v, i + (c + 1) * sy, sy, nx):
            c += 1
        return 1, c
    if z > 0 and _same_row(v, i, sz, nx):
        c = 0
        left = (nz - z) * ny - y - 1  # rows after this one
        while c < left and _same_row(v, i + (c + 1) * sy, sz, nx):
            c += 1
        return 2, c
    return 0, 0


@kernel(nrt=False)
def _tokens_kernel(v, shape, lo, hi, pid, cid, runs, rows, toks, ctxs, u, counts, bits):
    """Forward pass of the encoder: every symbol's token and context (``toks``,
    ``ctxs``: room for two a voxel), the counts per (context, token), and the raw low
    bits written to ``bits`` (LSB first). With ``runs``, a voxel inside the rows whose
    activity is 0 starts a run: the count of voxels from it on (C order) whose residual
    is 0 is coded (context :data:`RUN_LENGTH`), then the voxel that ends the run before
    the brick's end (context :data:`RUN_BREAK`). With ``rows`` (and ``runs``) a row
    but the brick's first, not inside a copy run, starts with its kind (:func:`_row_run`,
    context :data:`ROW_KIND` plus the previous row's kind), a copy kind then with the
    count of the rows after it that copy alike (context :data:`ROW_COUNT` plus kind
    - 1); copied rows code nothing more and leave residuals 0, and a run of voxels
    stops at its row's end (then no voxel ends it).
    Returns ``(raw bits, symbols, voxels in runs, voxels in copied rows)``; raw bits -1
    when ``bits`` is too small."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sy, sz = nx, ny * nx
    mid = (lo + hi) >> 1
    acc = np.uint64(0)
    nacc = 0
    bpos = 0
    k = 0  # symbols so far
    inrun = False
    length = 0
    covered = 0  # voxels inside runs
    copied = 0  # voxels of copied rows
    prev = 0  # the kind of the row before
    copies = 0  # rows left in the current copy run
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        for y in range(ny):
            if rows and (y > 0 or z > 0) and copies == 0:
                kind, more = _row_run(v, i, nx, ny, nz, y, z)
                bpos, acc, nacc = emit(
                    toks, ctxs, counts, k, ROW_KIND + prev, kind, bits, bpos, acc, nacc
                )
                k += 1
                prev = kind
                if kind != 0:
                    bpos, acc, nacc = emit(
                        toks, ctxs, counts, k, ROW_COUNT + kind - 1, more, bits, bpos, acc, nacc
                    )
                    k += 1
                    copies = more + 1
            if copies > 0:
                copies -= 1
                for x in range(nx):
                    u[cur + y * nx + x] = 0
                i += nx
                copied += nx
                continue
            for x in range(nx):
                p = min(max(_predict(v, i, z, y, x, sy, sz, pid, mid), lo), hi)
                r = cur + y * nx + x
                e = v[i] - p
                ue = (e << 1) if e >= 0 else ((-e) << 1) - 1
                c = np.int64(RUN_BREAK)
                if not inrun:
                    c = _context(v, u, i, r, sz - cur + y * nx + x, z, y, x, nx, cid)
                    if runs and c == 0 and y > 0 and 0 < x < nx - 1:
                        inrun = True
                        length = 0
                u[r] = ue
                i += 1
                if inrun:
                    if ue == 0:
                        length += 1
                        covered += 1
                        if rows and x == nx - 1:  # the run stops with its row
                            inrun = False
                            bpos, acc, nacc = emit(
                                toks, ctxs, counts, k, RUN_LENGTH, length, bits, bpos, acc, nacc
                            )
                            k += 1
                        continue
                    inrun = False
                    bpos, acc, nacc = emit(
                        toks, ctxs, counts, k, RUN_LENGTH, length, bits, bpos, acc, nacc
                    )
                    k += 1
                    c = RUN_BREAK
                bpos, acc, nacc = emit(toks, ctxs, counts, k, c, ue, bits, bpos, acc, nacc)
                k += 1
                if bpos < 0:
                    return -1, k, covered, copied
    if inrun:  # the last run ends with the brick
        bpos, acc, nacc = emit(toks, ctxs, counts, k, RUN_LENGTH, length, bits, bpos, acc, nacc)
        k += 1
        if bpos < 0:
            return -1, k, covered, copied
    if nacc > 0:
        bits[bpos] = np.uint8(acc & np.uint64(0xFF))
        bpos += 1
    return bpos * 8 - ((8 - nacc) & 7), k, covered, copied


@kernel(inline=True)
def _flat_until(v, i, end, sy, sz, pz):
    """The first voxel of ``i .. end - 1`` (in a row, x > 0, y > 0, inside a run) not
    predicted as W's value, else ``end``: N equal to NW makes MED give W, and (with the
    3-D correction, ``pz``) U equal to UW and UN to UNW make the correction 0; since
    the run's residuals are 0, W's value then repeats. A first pass without an exit
    (which the compiler vectorises) settles the common case, a flat segment."""
    diff = v[0] ^ v[0]
    if pz != 0:
        for j in range(np.uintp(i), np.uintp(end)):
            k = j - np.uintp(sy)
            m = j - np.uintp(sz)
            q = k - np.uintp(sz)
            diff |= (v[k] ^ v[k - ONE]) | (v[m] ^ v[m - ONE]) | (v[q] ^ v[q - ONE])
    else:
        for j in range(np.uintp(i), np.uintp(end)):
            k = j - np.uintp(sy)
            diff |= v[k] ^ v[k - ONE]
    if diff == 0:
        return end
    for j in range(np.uintp(i), np.uintp(end)):
        k = j - np.uintp(sy)
        if v[k] != v[k - ONE]:
            return np.int64(j)
        if pz != 0:
            m = j - np.uintp(sz)
            if v[m] != v[m - ONE] or v[k - np.uintp(sz)] != v[k - np.uintp(sz) - ONE]:
                return np.int64(j)
    return end


@kernel(inline=True)
def take_symbol(syms, info, c, data, pos, x0, x1, words, reader, tok):
    """Decode the next zig-zagged number: its token from state ``x0`` in context ``c``
    (:func:`volpack.entropy.rans.decode_symbol_split`), then its raw low bits from the
    bit reader ``(acc, nacc, k)`` (``nacc`` bits in ``acc``, ``k`` 32-bit words of
    ``words`` read). Returns ``(u, pos, x1, x0, reader)``: the states swapped, so the
    two take the symbols in turn. ``words`` ends with a 0 word past the stream, which
    every read beyond the end gets."""
    acc, nacc, k = reader
    t, x0, pos = rans.decode_symbol_split(data, x0, pos, c << 12, syms, info)
    e = tok[np.uintp(t)]
    nb = e & 63
    if nacc <= 32:  # refill: a raw field is at most 30 bits
        acc |= np.uint64(words[np.uintp(min(k, words.size - 1))]) << np.uint64(nacc)
        nacc += 32
        k += 1
    ue = (e >> 6) + np.int64(acc & ((np.uint64(1) << np.uint64(nb)) - np.uint64(1)))
    return ue, pos, x1, x0, (acc >> np.uint64(nb), nacc - nb, k)


@kernel(inline=True)
def _next_row(x, y, z, r, nx, ny, ring):
    """The position (and ring slot) after a step that ended at ``x`` (at most ``nx``):
    the next row's first voxel when the row is done, the next slice's after its last
    row."""
    if x == nx:
        x = 0
        y += 1
        if y == ny:
            y = 0
            z += 1
            if r == ring:
                r = 0
    return x, y, z, r


@kernel(nrt=False)
def _decode_kernel(
    data, words, nbits, syms, info, nctx, pid, cid, runs, rows, shape, lo, hi, v, u, tok, act, kinds
):  # fmt: skip
    """Decode a brick into ``v`` (flat; ``u`` a zeroed int32 ring of two slices: voxel
    ``i``'s residual, capped at :data:`UCAP`, in slot ``i mod 2 ny nx``); 0, or a
    :data:`STATUS` code. ``data`` (the rANS stream) and ``words`` (the raw bits, 32-bit
    little-endian words) carry the zero padding :func:`take_symbol` reads past their ends;
    ``nbits`` counts the raw stream's bits. Inside a row the loop keeps W and its
    residual in registers, reads the neighbours without edge tests or signed indices
    and looks the context class up (``act``); a run (``runs``) fills its voxels at once;
    edges and the voxel that ends a run go through :func:`_predict` and
    :func:`_context`, as in the encoder. With ``rows`` each row but the first starts
    with its kind: a copy (of N or U) is one vectorised copy, its kind noted in ``kinds``
    (one byte a row, zeroed by the caller) for :func:`store_palette`. The position (z, y, x)
    and the ring slot ``r`` advance with ``i`` (no division a voxel)."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sy, sz = nx, ny * nx
    n = nz * sz
    ring = 2 * sz
    mid = (lo + hi) >> 1
    hictx = nctx - 1
    span = np.uint64(hi - lo)
    x0, x1, pos = rans.open_states(data)
    reader = (np.uint64(0), np.int64(0), np.int64(0))
    bad = False
    brk = False  # voxel i ends a run
    prev = 0  # the kind of the row before (rows)
    i = 0
    z = y = x = r = 0
    while i < n:
        pz = pid if z > 0 else 0
        if rows and x == 0 and (y > 0 or z > 0):
            kind, pos, x0, x1, reader = take_symbol(
                syms, info, nctx + 2 + prev, data, pos, x0, x1, words, reader, tok
            )
            prev = kind
            if kind != 0:
                if not (kind == 1 and y > 0) and not (kind == 2 and z > 0):
                    return 5
                more, pos, x0, x1, reader = take_symbol(
                    syms, info, nctx + 4 + kind, data, pos, x0, x1, words, reader, tok
                )
                if more >= (ny - y if kind == 1 else (nz - z) * ny - y):
                    return 5
                back = np.uintp(sy if kind == 1 else sz)
                m = more + 1
                q = z * ny + y + m  # the row after the run
                for t in range(q - m, q):  # each row a copy, vectorised (no overlap in a row)
                    for j in range(np.uintp(i), np.uintp(i + nx)):
                        v[j] = v[j - back]
                    kinds[t] = kind
                    i += nx
                for t in range(q - min(m, 2 * ny), q):  # residuals 0: each ring row once
                    s0 = np.uintp((((t // ny) & 1) * ny + t % ny) * nx)
                    for j in range(s0, s0 + np.uintp(nx)):
                        u[j] = 0
                z, y = q // ny, q % ny
                r = (z & 1) * sz + y * nx
                continue
        if not brk and y > 0 and 0 < x < nx - 1:  # the inside of a row, up to its last voxel
            w = np.int64(v[i - 1])
            uw = np.int64(u[r - 1])
            d = sz if r < sz else -sz  # from a slot to the slot of U
            run = False
            while x < nx - 1:
                k = np.uintp(i - sy)
                nn = np.int64(v[k])
                nw = np.int64(v[k - ONE])
                ne = np.int64(v[k + ONE])
                p = _med(w, nn, nw)
                if pz != 0:
                    j = np.uintp(i - sz)
                    m = _med(
                        np.int64(v[j - ONE]),
                        np.int64(v[np.uintp(i - sz - sy)]),
                        np.int64(v[np.uintp(i - sz - sy - 1)]),
                    )
                    p = _correct(p, v[j] - m, pz)
                p = min(max(p, lo), hi)
                q = np.uintp(r - nx)
                a = np.int64(u[q]) + u[q - ONE] + u[q + ONE] + u[np.uintp(r + d)]
                g = abs(nn - nw) + abs(ne - nn)
                if cid == 0:
                    a += uw
                    g += abs(w - nw)
                if runs and a + g == 0:
                    run = True
                    break
                c = a + 2 * g  # its class, capped at the last context: one look-up
                c = np.int64(act[np.uintp(c)]) if c < act.size else min(_activity(c), hictx)
                uw, pos, x0, x1, reader = take_symbol(
                    syms, info, c, data, pos, x0, x1, words, reader, tok
                )
                u[np.uintp(r)] = min(uw, UCAP)
                w = p + ((uw >> 1) ^ -(uw & 1))
                bad |= np.uint64(w - lo) > span  # outside [lo, hi]: one compare
                v[np.uintp(i)] = w
                i += 1
                r += 1
                x += 1
            if not run:
                continue
            length, pos, x0, x1, reader = take_symbol(
                syms, info, nctx, data, pos, x0, x1, words, reader, tok
            )
            if length > (nx - x if rows else n - i):
                return 4
            end = i + length
            while i < end:  # voxels whose residual is 0: the prediction
                seg = i
                if y > 0 and x > 0:
                    seg = _flat_until(v, i, min(end, i + nx - x), sy, sz, pz)
                if seg > i:
                    w = v[i - 1]  # every prediction up to seg is W's value
                    for j in range(np.uintp(i), np.uintp(seg)):
                        v[j] = w
                    for j in range(np.uintp(r), np.uintp(r + seg - i)):
                        u[j] = 0
                    r += seg - i
                    x += seg - i
                    i = seg
                elif y > 0 and x > 0:  # to the segment's end, W kept in a register
                    seg = min(end, i + nx - x)
                    w = np.int64(v[i - 1])
                    for j in range(np.uintp(i), np.uintp(seg)):
                        k = j - np.uintp(sy)
                        p = _med(w, np.int64(v[k]), np.int64(v[k - ONE]))
                        if pz != 0:
                            m = j - np.uintp(sz)
                            q = k - np.uintp(sz)
                            c3 = _med(np.int64(v[m - ONE]), np.int64(v[q]), np.int64(v[q - ONE]))
                            p = _correct(p, v[m] - c3, pz)
                        w = min(max(p, lo), hi)
                        v[j] = w
                        u[j - np.uintp(i - r)] = 0
                    r += seg - i
                    x += seg - i
                    i = seg
                else:
                    v[i] = min(max(_predict(v, i, z, y, x, sy, sz, pz, mid), lo), hi)
                    u[r] = 0
                    i += 1
                    r += 1
                    x += 1
                x, y, z, r = _next_row(x, y, z, r, nx, ny, ring)
                pz = pid if z > 0 else 0
            brk = x > 0 if rows else i < n  # with rows, a run ends at its row's end
            continue
        p = min(max(_predict(v, i, z, y, x, sy, sz, pz, mid), lo), hi)
        if brk:
            c = nctx + 1
            brk = False
        else:
            ru = r + sz if r < sz else r - sz
            c = min(_context(v, u, i, r, ru, z, y, x, nx, cid), hictx)
        ue, pos, x0, x1, reader = take_symbol(syms, info, c, data, pos, x0, x1, words, reader, tok)
        u[r] = min(ue, UCAP)
        val = p + ((ue >> 1) ^ -(ue & 1))
        bad |= (val < lo) | (val > hi)
        v[i] = val
        i += 1
        r += 1
        x, y, z, r = _next_row(x + 1, y, z, r, nx, ny, ring)
    if bad:
        return 2
    used = 32 * reader[2] - reader[1]  # raw bits consumed
    if pos > data.size - 2 or used > nbits:
        return 1
    if not rans.state_ok(data, x0, x1, pos) or (used + 7) >> 3 != (nbits + 7) >> 3:
        return 3
    return 0


def decode_ns(coded: int, runs: int, filled: int, copied: int, nx: int) -> float:
    """A model of a brick's decode time (ns per core, fitted on the bricks of the liver
    labels and the head CT): voxels decoded one by one, runs (a symbol, a flat check and
    the voxel that ends it), voxels filled by runs (and a row segment of ``nx`` each)
    and voxels of copied rows."""
    return 15.0 * coded + 60.0 * runs + (0.6 + 40.0 / nx) * filled + 0.2 * copied


def cap_contexts(counts: np.ndarray) -> tuple[int, np.ndarray, float]:
    """Choose how many activity classes keep their own table (the top ones merge into
    the last) by the coded size, tables included: ``(nctx, freqs, bits)``."""
    used = np.flatnonzero(counts.sum(axis=1))
    top = int(used[-1]) + 1 if used.size else 1
    best = None
    # a row's table does not depend on the others: the classes below every cut are
    # scaled once, not once a cut (13 cuts: 20 % of the encode of a head CT brick)
    own = rans.normalise(counts[: top - 1])
    own_bytes = np.cumsum(_row_table_bytes(own))  # and their tables' bytes summed once
    for nctx in range(max(1, top - 12), top + 1):
        merged = counts[:nctx].copy()
        merged[nctx - 1] += counts[nctx:].sum(axis=0)
        last = rans.normalise(merged[nctx - 1 :])
        freqs = np.vstack([own[: nctx - 1], last])
        head = int(_row_table_bytes(last)[0]) + (int(own_bytes[nctx - 2]) if nctx > 1 else 0)
        cost = _symbol_bits(merged, freqs) + 8 * head
        if best is None or cost < best[2]:
            best = (nctx, freqs, cost)
    return best


def _coded_bits(counts: np.ndarray, freqs: np.ndarray) -> float:
    """The bits of the symbols ``counts`` under the tables ``freqs``, the tables' own
    bytes included."""
    return _symbol_bits(counts, freqs) + 8 * int(_row_table_bytes(freqs).sum())


def _symbol_bits(counts: np.ndarray, freqs: np.ndarray) -> float:
    """The bits of the symbols ``counts`` under the tables ``freqs``, tables left out."""
    used = counts > 0
    return -(counts[used] * np.log2(freqs[used] / rans.TOTAL)).sum()


def _row_table_bytes(freqs: np.ndarray) -> np.ndarray:
    """Each row's share of ``len(pack_tables(freqs))``, without packing (numbers below
    2^14: one LEB128 byte below 128, else two)."""
    nz = freqs > 0
    t = np.where(nz.any(axis=1), freqs.shape[1] - np.argmax(nz[:, ::-1], axis=1), 0)
    inside = np.arange(freqs.shape[1]) < t[:, None]
    return (1 + (t >= 128)) + (inside * (1 + (freqs >= 128))).sum(axis=1)


def pack_tables(freqs: np.ndarray) -> bytes:
    """Per context: ``uleb T`` (entries for tokens ``0..T-1``; 0: an unused context),
    then ``T`` frequencies as ``uleb``."""
    out = bytearray()
    for row in freqs:
        nz = np.flatnonzero(row)
        t = int(nz[-1]) + 1 if nz.size else 0
        out += pal.uleb(t)
        for f in row[:t]:
            out += pal.uleb(int(f))
    return bytes(out)


@kernel(inline=True)
def _read_uleb(data, pos):
    """An unsigned LEB128 number of at most 63 bits at ``pos``: ``(value, pos)``, the
    position -1 when it runs past ``data`` or is longer."""
    v = np.int64(0)
    shift = 0
    while pos < data.size and shift < 63:
        b = np.int64(data[pos])
        pos += 1
        v |= (b & 0x7F) << shift
        if b < 0x80:
            return v, pos
        shift += 7
    return v, np.int64(-1)


@kernel(nrt=False)
def tables_kernel(data, pos, syms, info):
    """Read the frequency tables of :func:`pack_tables` from ``data[pos:]`` into the
    decoder's split look-up (:func:`volpack.entropy.rans.decode_symbol_split`: one row
    of ``syms`` and of ``info`` per context; every slot of an unused context decodes to
    :data:`BAD_SYMBOL`, a token no residual makes, so to a value outside any range).
    Returns the position after them, or -1 (past the end), -2 (too many tokens), -3 (a
    table that does not sum to the total, or gives one token all of it)."""
    for c in range(syms.shape[0]):
        t, pos = _read_uleb(data, pos)
        if pos < 0:
            return -1
        if t > NTOK:
            return -2
        slot = 0
        for k in range(t):
            f, pos = _read_uleb(data, pos)
            if pos < 0:
                return -1
            if f >= rans.TOTAL or slot + f > rans.TOTAL:
                return -3
            syms[c, slot : slot + f] = k
            info[c, k] = f | (slot << 13)
            slot += f
        if t == 0:
            syms[c, :] = BAD_SYMBOL
            info[c, BAD_SYMBOL] = rans.TOTAL  # the state stays as it is
        elif slot != rans.TOTAL:
            return -3
    return pos


def _work_dtype(lo: int, hi: int) -> np.dtype:
    """What the decoder writes: uint8 for ``[lo, hi]`` inside 0..255 (label ranks and
    8-bit scans: a quarter of the memory traffic, 0.82-0.95x the decode time on liver,
    AAL and ``ch2bet``), else int32 when it holds the range, else int64 (three compiled
    variants of each decoder, not one per voxel dtype)."""
    if 0 <= lo and hi < 256:
        return np.dtype(np.uint8)
    return np.dtype(np.int32) if -(1 << 31) <= lo and hi < (1 << 31) else np.dtype(np.int64)


def encode(
    values: np.ndarray,
    lo: int,
    hi: int,
    predictor: str | None = None,
    context: str | None = None,
    runs: bool | None = None,
    rows: bool | None = None,
    report: dict | None = None,
) -> bytes:
    """Code a 3-D integer array with values in ``[lo, hi]`` (span below 2^32): the
    predictor and context byte, the tables, the rANS words and the raw bits.

    By default the encoder measures every predictor with the ``far`` context, then the
    best one with ``near``, and keeps ``near`` only when it saves more than
    :data:`NEAR_GAIN` (it decodes about a third slower: W joins the decoder's chain
    from one voxel to the next); then the best with the run mode, kept unless it costs
    more than :data:`RUN_SLACK` of the bits or :data:`RUN_BITS` a voxel, times the squared
    share of voxels in runs; then that with the row kinds (:data:`ROWS`), kept by the
    same rule against the stream without runs, on the share of voxels in runs or copied
    rows. ``predictor`` / ``context`` / ``runs`` / ``rows`` force one (tests, studies;
    ``runs=False`` writes the streams of before the run mode, ``rows=False`` those of
    before the row kinds). ``report`` (a dict), when given, gets ``ns``: the modelled
    decode time of the stream written (:func:`decode_ns`).
    """
    v = checked_input(values, lo, hi)
    shape = np.array(v.shape, dtype=np.int64)
    flat = v.reshape(-1)
    n = flat.size
    ring = np.zeros(2 * v.shape[1] * v.shape[2], dtype=np.int64)

    size = 2 * n + v.shape[0] * v.shape[1]
    spare = []  # the work arrays of trials that lost, for the next trial (a brick of 2^18
    # voxels wrote 2.5 MB of fresh pages a trial, six to twelve trials a brick)

    def trial(pid: int, cid: int, run: bool, row: bool = False) -> tuple:
        work = spare.pop() if spare else (
            np.empty(size, dtype=np.uint8), np.empty(size, dtype=np.uint8),
            np.empty(4 * n + 16, dtype=np.uint8),
        )  # fmt: skip
        toks, ctxs, bits = work
        counts = np.zeros((ROW_KIND + ROW_TABLES, rans.MAX_SYMBOLS), dtype=np.int64)
        nbits, nsym, covered, copied = _tokens_kernel(
            flat, shape, np.int64(lo), np.int64(hi), pid, cid, run, row, toks, ctxs, ring,
            counts, bits,
        )  # fmt: skip
        nctx, freqs, cost = cap_contexts(counts[:NCLASS])
        if run:
            more = counts[NCLASS : ROW_KIND + ROW_TABLES * row]
            extra = rans.normalise(more)
            cost += _coded_bits(more, extra)
            freqs = np.vstack([freqs, extra])
        share = (covered + copied) / n
        spent = decode_ns(
            n - covered - copied, counts[RUN_LENGTH].sum(), covered, copied, v.shape[2]
        )
        return cost + nbits, pid, cid, run, row, nctx, freqs, (work, nsym, nbits), spent, share

    def drop(t: tuple) -> None:
        """A trial that will not be written: its arrays serve the next one."""
        spare.append(t[7][0])

    timed = rows is not False  # the encoder of the row kinds also weighs decode time

    def cheap(fast: tuple, base: tuple) -> bool:
        """Whether ``fast`` costs at most its allowance over ``base``: the run rule, or
        (``timed``) :data:`NS_BITS` a nanosecond of decode it saves."""
        extra = fast[0] - base[0]
        rule = max(RUN_SLACK * base[0], RUN_BITS * n) * fast[-1] ** 2
        return extra <= max(rule, NS_BITS * (base[-2] - fast[-2]) if timed else 0)

    def score(t: tuple) -> float:
        return t[0] + NS_BITS * t[-2]

    pids = [PREDICTORS.index(predictor)] if predictor else range(len(PREDICTORS))
    if v.shape[0] == 1:  # one slice: the 3-D predictors are MED
        pids = [0]
    far = CONTEXTS.index("far")
    cids = [CONTEXTS.index(context)] if context else [far]
    first = bool(runs)
    if rows and runs is False:
        raise OptionError("rows: the row kinds go with the run mode, found runs=False")
    best = None
    for pid in pids:
        for cid in cids:
            t = trial(pid, cid, first)
            if best is None or t[0] < best[0]:  # the first of equals, as min() kept
                if best is not None:
                    drop(best)
                best = t
            else:
                drop(t)
    if context is None:
        near = trial(best[1], CONTEXTS.index("near"), first)
        if near[0] * (1 + NEAR_GAIN) < best[0]:
            drop(best)
            best = near
        else:
            drop(near)
    plain = best  # its cost still judges the row kinds, its arrays may go
    if runs is None:
        run = trial(best[1], best[2], True)
        if cheap(run, plain):
            drop(plain)
            best = run
        else:
            drop(run)
    if rows or (rows is None and runs is not False):
        row = trial(best[1], best[2], True, True)
        if rows or cheap(row, plain) and (best is plain or score(row) <= score(best)):
            drop(best)
            best = row
        else:
            drop(row)
    _, pid, cid, run, row, nctx, freqs, (work, nsym, nbits), spent, _ = best
    if report is not None:
        report["ns"] = spent
    # only the trial written maps its contexts and copies its raw bits
    toks = work[0][:nsym]
    ctx = work[1][:nsym].astype(np.int64)
    ctx = np.where(ctx >= NCLASS, ctx - NCLASS + nctx, np.minimum(ctx, nctx - 1))
    raw = work[2][: (nbits + 7) >> 3].tobytes()
    stream = rans.encode(toks, ctx, freqs)
    choice = pid | (cid << 2) | (RUNS if run else 0) | (ROWS if row else 0)
    head = bytes([choice]) + pal.uleb(nctx) + pack_tables(freqs)
    return head + pal.uleb(len(stream)) + stream + raw


HEAD_STATUS = {
    -1: "a frequency table runs past the payload",
    -2: "a frequency table has too many tokens",
    -3: "a frequency table does not sum to M",
    -4: "missing predictor byte",
    -5: "unknown predictor/context byte",
    -6: f"contexts out of 1..{NCLASS}",
    -7: "the rANS stream runs past the payload",
}


@kernel(nrt=False)
def _head_kernel(buf, syms, info, act, stream, words, ring, kinds):
    """Set up the decode of the stream ``buf`` without the GIL: read its head (the
    choice byte, the context count and the tables into ``syms`` / ``info``, which have
    room for every table), copy the rANS bytes and the raw bits into ``stream`` and
    ``words`` (room for ``buf`` and the padding) with the zero padding
    :func:`_decode_kernel` reads, zero ``ring`` and ``kinds``, and cap ``act``
    (:data:`ACTIVITY`) at the last context. Before, a dozen NumPy calls and allocations
    did this holding the GIL, about 50 us a coded brick of MNI152. Returns ``(status,
    choice byte, contexts, rANS bytes, raw bytes)``, the status 0 or a
    :data:`HEAD_STATUS` code. (Not a caller of :func:`_decode_kernel`: numba would
    optimise the decoder again inside it, 0.9 s more compile time a process.)"""
    if buf.size == 0:
        return -4, 0, 0, 0, 0
    b = np.int64(buf[0])
    runs, rows = (b & RUNS) != 0, (b & ROWS) != 0
    if b & 3 >= NPRED or (b & ~(RUNS | ROWS)) >> 2 >= NCTXR or (rows and not runs):
        return -5, b, 0, 0, 0
    nctx, pos = _read_uleb(buf, 1)
    if pos < 0 or not 1 <= nctx <= NCLASS:
        return -6, b, nctx, 0, 0
    ntab = nctx + 2 * runs + ROW_TABLES * rows
    pos = tables_kernel(buf, pos, syms[:ntab], info[:ntab])
    if pos < 0:
        return pos, b, nctx, 0, 0
    nbytes, pos = _read_uleb(buf, pos)
    if pos < 0 or nbytes > buf.size - pos:
        return -7, b, nctx, 0, 0
    for j in range(nbytes):
        stream[j] = buf[pos + j]
    stream[nbytes] = 0
    stream[nbytes + 1] = 0
    pos += nbytes
    nraw = buf.size - pos
    for j in range((nraw + 3) // 4 + 1):  # and a 0 word past the end
        words[j] = 0
    for j in range(nraw):
        words[j >> 2] |= np.uint32(buf[pos + j]) << np.uint32(8 * (j & 3))
    for j in range(ring.size):
        ring[j] = 0
    for j in range(kinds.size):
        kinds[j] = 0
    for j in range(act.size):
        act[j] = min(ACTIVITY[j], nctx - 1)
    return 0, b, nctx, nbytes, nraw


class _Scratch(threading.local):
    """Each thread's work arrays for :func:`decode` (grown to the largest brick and
    payload seen, reused: no allocation a brick)."""

    def __init__(self) -> None:
        ntab = NCLASS + 2 + ROW_TABLES
        self.syms = np.empty((ntab, rans.TOTAL), dtype=np.uint8)
        self.info = np.empty((ntab, rans.MAX_SYMBOLS), dtype=np.uint32)
        self.act = np.empty(ACTIVITY.size, dtype=np.uint8)
        self.flat_syms, self.flat_info = self.syms.reshape(-1), self.info.reshape(-1)
        self.bufs: dict = {}

    def get(self, name: str, n: int, dtype) -> np.ndarray:
        """An array ``name`` of ``n`` items of ``dtype`` (a view of one kept)."""
        a = self.bufs.get(name)
        if a is None or a.size < n or a.dtype != dtype:
            a = self.bufs[name] = np.empty(max(n, 1024), dtype=dtype)
        return a[:n]


_scratch = _Scratch()


def decode(
    data: bytes | memoryview,
    shape: tuple[int, int, int],
    lo: int,
    hi: int,
    kinds: np.ndarray | None = None,
    reuse: bool = False,
) -> np.ndarray:
    """Decode :func:`encode`'s bytes into an integer array of ``shape`` (of
    :func:`_work_dtype`: the smallest of uint8, int32 and int64 that holds the range);
    ``kinds`` (uint8, one a row) gets the kind of each copied row (1 N, 2 U).
    ``reuse``: the array is this thread's work array, valid until its next call (for a
    caller that copies it out at once)."""
    if not (lo <= hi and hi - lo < (1 << 32)):
        raise FormatError(f"fast stream: value range [{lo}, {hi}] is out of bounds")
    buf = read_only(np.frombuffer(data, dtype=np.uint8))
    n = math.prod(shape)
    sc = _scratch
    wd = _work_dtype(lo, hi)
    v = sc.get("v" + wd.char, n, wd) if reuse else np.empty(n, dtype=wd)
    ring = sc.get("ring", 2 * shape[1] * shape[2], np.int32)
    kinds = sc.get("kinds", shape[0] * shape[1], np.uint8) if kinds is None else kinds
    stream = sc.get("stream", buf.size + 2, np.uint8)
    words = sc.get("words", buf.size // 4 + 2, np.uint32)
    status, b, nctx, nbytes, nraw = _head_kernel(
        buf, sc.syms, sc.info, sc.act, stream, words, ring, kinds
    )
    if status:
        raise FormatError(f"fast stream: {HEAD_STATUS[int(status)]}")
    status = _decode_kernel(
        stream[: nbytes + 2], words[: (nraw + 3) // 4 + 1], np.int64(8 * nraw), sc.flat_syms,
        sc.flat_info, np.int64(nctx), b & 3, (b & ~(RUNS | ROWS)) >> 2, bool(b & RUNS),
        bool(b & ROWS), np.array(shape, dtype=np.int64), np.int64(lo), np.int64(hi), v, ring,
        TOK, sc.act, kinds,
    )  # fmt: skip
    if status:
        raise FormatError(f"corrupt fast-coded brick: {STATUS.get(int(status), status)}")
    return v.reshape(shape)


@kernel(nrt=False)
def _palette_kernel(ranks, p, out, kinds):
    """``out = p[ranks]``, a copied row (``kinds``) copied from ``out`` itself."""
    nz, ny, nx = out.shape
    i = 0
    for z in range(nz):
        for y in range(ny):
            k = kinds[z * ny + y]
            if k == 1:
                for x in range(nx):
                    out[z, y, x] = out[z, y - 1, x]
            elif k == 2:
                for x in range(nx):
                    out[z, y, x] = out[z - 1, y, x]
            else:
                for x in range(nx):
                    out[z, y, x] = p[np.uintp(ranks[i + x])]
            i += nx


def store_palette(
    ranks: np.ndarray, p: np.ndarray, out: np.ndarray, kinds: np.ndarray | None = None
) -> None:
    """Write the values ``p[ranks]`` of a decoded brick of palette ranks (:func:`decode`
    checked each below ``len(p)``) into ``out``, a 3-D view of the same shape and
    ``p``'s dtype (any strides): one pass instead of a gather and a copy; the rows
    ``kinds`` marks as copies (:func:`decode`) are copied in ``out`` instead."""
    nrows = out.shape[0] * out.shape[1]
    _palette_kernel(
        ranks.reshape(-1), p, out, np.zeros(nrows, np.uint8) if kinds is None else kinds
    )
