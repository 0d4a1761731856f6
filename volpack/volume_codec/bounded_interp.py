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
is rough) and the bin coded just before it. Or (kind bit 4, the encoder's choice by size)
by :mod:`.predictfit`'s adaptive binary coder, in contexts of the predicting and the same
pass's neighbouring bins: no tables to store, and models that follow the bins' spread
where the static contexts saturate (every bin past 16 at tight bounds). Or (kind bit 5,
effort 'fast' only) grouped for decoding speed (:data:`GROUPED`): the bins are decoded
in a pass of their own, then the walk takes them from an array, with no contexts. The
static coding's contexts may share tables (kind bit 6, :data:`SHARED`; session 35):
where the bins are nearly all 0, 18 tables cost more than their contexts save.

The encoder's choices, made per brick by the estimated coded size and stored: which
axis is interpolated in which order (the pass of the last axis covers half the voxels,
so the smoothest axis goes last), cubic or linear (linear wins on noise), and a finer
step on the coarse levels (their errors are propagated to every finer level).
"""

from __future__ import annotations

import struct

import numpy as np

from .._jit import inline_into, kernel, leading_zeros
from ..entropy import rans
from ..entropy.common import encode_with_retry, stream_bytes
from ..entropy.rangecoder import end_status, finish_stream, open_encoder, open_stream
from ..errors import FormatError
from ..format.deflate import deflate, inflate
from ..format.sections import put_section, take_section
from .predict import NCTX as A_NCTX
from .predict import NO_RESIDUAL, activity_class
from .predictfit import MODEL_INIT, N_MODELS, get_residual, put_residual

MAX_BIN = 2.0**30  # larger bins (or no finite residual): bin 0, left to the corrections
DIRECT = 32  # zigzagged bins below this are symbols themselves
N_SYM = DIRECT + 2 * (31 - 6) + 2  # bit lengths 6..31 of larger ones, two symbols each
N_ACT = 6  # classes of the interpolating voxels' bins
N_PREV = 3  # classes of the previous bin: 0, 1, more
N_CTX = N_ACT * N_PREV
KINDS = (1, 0, 2, 3)  # cubic, linear, Lorenzo 3-D, Lorenzo 2-D
PERMS = ((0, 1, 2), (1, 0, 2), (2, 1, 0), (0, 2, 1))
HEADER = struct.Struct("<3BB")  # axis order, kind
# Kind flag: the bins coded by the adaptive binary coder (below) instead of static rANS.
ADAPTIVE = 16
# Kind flag: the bins coded in groups for decoding speed (effort 'fast' only): decoded
# in a pass of their own, then the walk predicts without contexts. A group of GROUP
# bins in walk order has a class, the bit length of its largest symbol (0: all bins 0,
# nothing more is coded); the class is coded in the context of the previous group's,
# then the group's symbols in context N_CLASS - 1 + c, PACK[c] to a token (c bits each,
# the first lowest): fewer tokens where the symbols are small, the common case at loose
# bounds, and never longer (a pair's entropy is at most its parts'). GROUP_BITS of
# precision: the 15 tables (4 KB each) fit in the L1 cache, where the 18 of 16 KB of
# the static coding did not. The tokens alternate between two rANS streams (lanes) of
# two states each: a state's renormalisation reads at its stream's position, so with
# one stream every symbol waited for the one before; two lanes overlap.
GROUPED = 32
# Kind flag: the static coding's contexts share tables (session 35, lossy35): the tables
# section holds K, a table index for each of the N_CTX contexts, then K tables. On a
# brick whose bins are nearly all 0 the 18 tables cost more than their contexts save:
# a field interpolated trilinearly up 8x from a 13^3 grid at 1e-2 of its range spent
# 465 of its 2,295 bytes on tables (SZ3's whole file: 2,072). Made beside the plain
# tables and kept where shorter.
SHARED = 64
SHARE_TABLE_BITS = 12.0  # what an entry of a table costs, deflated (the merge's guide)
SHARED_TABLES = True  # the encoder makes the shared coding (off: as before session 35)
GROUP = 16
N_CLASS = 8  # N_SYM <= 128: bit lengths 0..7
N_GROUP_CTX = 2 * N_CLASS - 1
GROUP_BITS = 10
PACK = np.array([1, 4, 2, 2, 1, 1, 1, 1])  # symbols a token, by class (tokens < N_SYM)


def _unpacked() -> np.ndarray:
    """The bins of each packed token (classes 1-3, tokens below 64), four a row (zeros
    past the token's own): the decoder copies a row instead of splitting the token."""
    out = np.zeros((4, 64, 4), dtype=np.int32)
    for c in (1, 2, 3):
        for v in range(1 << (c * PACK[c])):
            for i in range(PACK[c]):
                u = (v >> (c * i)) & ((1 << c) - 1)
                out[c, v, i] = (u >> 1) ^ -(u & 1)
    return out


UNPACKED = _unpacked()
# Indices of the walk's arrays as unsigned: numba tests a signed index for a negative
# wrap-around (1.12-1.19x on the interpolation kinds' adaptive decoding, ldec31).
_U = np.uint64
# What the encoder tries: (kind, axis orders). Lorenzo in 3-D hardly depends on the
# order; in 2-D the order's first axis is the one left out.
TRIED = ((1, PERMS), (0, PERMS), (2, PERMS[:1]), (3, PERMS[:3]))
# effort='fast': two walks instead of twelve: cubic interpolation (loose bounds) and 3-D
# Lorenzo (tight bounds), each in the stored order.
TRIED_FAST = ((1, PERMS[:1]), (2, PERMS[:1]))


@kernel(inline=True)
def _predict(rec, j, off, i, s, n, cubic):
    """Voxel ``j`` (flat) interpolated along an axis where it is ``i`` of ``n``, its
    known neighbours ``off`` (flat) = ``s`` (along the axis) apart."""
    b = rec[_U(j - off)]
    if i + s >= n:  # no neighbour after: the one before
        return b
    c = rec[_U(j + off)]
    if cubic == 0:
        return (b + c) * 0.5
    lo = i - 3 * s >= 0
    hi = i + 3 * s < n
    if lo and hi:
        return (9.0 * (b + c) - (rec[_U(j - 3 * off)] + rec[_U(j + 3 * off)])) * 0.0625
    if hi:  # the quadratic through -s, s, 3s
        return (3.0 * b + 6.0 * c - rec[_U(j + 3 * off)]) * 0.125
    if lo:  # the quadratic through -3s, -s, s
        return (6.0 * b + 3.0 * c - rec[_U(j - 3 * off)]) * 0.125
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
    """Append the ``n`` (< 32) low bits of ``v`` to ``raw`` (zeroed, 8 bytes of slack),
    least significant first."""
    w = (v & ((np.int64(1) << n) - 1)) << (bitpos & 7)
    i = bitpos >> 3
    for j in range(5):
        raw[i + j] |= np.uint8((w >> (8 * j)) & 0xFF)
    return bitpos + n


@kernel(inline=True)
def _get_bits(raw, bitpos, n):
    """``n`` (< 32) bits of ``raw`` from ``bitpos``: five byte loads, no loop over the
    bits (``raw`` ends in 8 zero bytes of slack; reading past its end is caught by the
    caller's final check)."""
    i = min(bitpos >> 3, raw.size - 8)
    w = np.int64(0)
    for j in range(5):
        w |= np.int64(raw[i + j]) << (8 * j)
    return (w >> (bitpos & 7)) & ((np.int64(1) << n) - 1)


@kernel(inline=True)
def _symbol_bin(u, raw, bitpos):
    """The bin of symbol ``u`` (:func:`_code_one`), its raw bits read from ``raw`` at
    ``bitpos``: (bin, bitpos)."""
    if u >= DIRECT:
        t = u - DIRECT
        n = 6 + (t >> 1)
        low = _get_bits(raw, bitpos, n - 2)
        bitpos += n - 2
        u = (np.int64(1) << (n - 1)) | ((t & 1) << (n - 2)) | low
    return (u >> 1) ^ -(u & 1), bitpos


@kernel(inline=True)
def _code_one(decode, v, p, q, c, k, sym, ctx, raw, bitpos, data, x0, x1, pos, table):
    """Quantise voxel value ``v`` against its prediction ``p`` in bins of ``q`` (encoding)
    or read its bin (decoding), in context ``c``. Returns (bin, k, bitpos, x0, x1, pos).

    Symbols: ``u`` = the bin zigzagged (0, -1, 1, -2, ... -> 0, 1, 2, 3, ...) when below
    :data:`DIRECT`; else ``DIRECT + 2 (n - 6) + h`` for ``u``'s bit length ``n`` and the
    bit ``h`` below its leading one, the ``n - 2`` bits under those going to ``raw``.
    """
    if decode:
        if k & 1:  # the two rANS states take turns
            u, x1, pos = rans.decode_symbol(data, x1, pos, c, table)
        else:
            u, x0, pos = rans.decode_symbol(data, x0, pos, c, table)
        b, bitpos = _symbol_bin(u, raw, bitpos)
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
    return b, k + 1, bitpos, x0, x1, pos


@kernel(inline=True)
def _adaptive_context(na, nb, sg):
    """The adaptive coder's context of a bin: the activity class of its neighbours' bin
    magnitudes ``na`` (those it was predicted from) plus ``nb`` (the same pass's voxels
    one step back along the two other axes), split three ways by how ``nb`` compares with
    ``na``; and the sign context: the sign of those back neighbours' bins summed (``sg``),
    as a prediction that is off tends to be off the same way nearby."""
    split = 0 if 2 * nb < na else (1 if nb < 2 * na else 2)
    ctx = min(activity_class(na + nb) * 3 + split, A_NCTX - 1)
    return ctx, (0 if sg < 0 else (1 if sg == 0 else 2))


@kernel(nrt=False, inline=inline_into("_decode_walk_adaptive"))
def _adaptive_bin(data, models, ac, sc, code, rng, pos):
    """One bin from the adaptive coder's stream (:func:`.predictfit.get_residual`):
    inlined into the adaptive decoding walk only (a call per voxel there cost 5 ns, a
    fifth of the walk at loose bounds); called, as dead code, from the other walks,
    which took half a minute each to compile with it inlined."""
    return get_residual(data, models, ac, sc, -1, code, rng, pos)


@kernel(inline=True)
def _code_any(decode, adaptive, v, p, q, c, na, nb, sg, k, state, sym, ctx, abin, adx,
              raw, data, table, models):  # fmt: skip
    """One voxel's bin (:func:`_code_one`) in static context ``c``; the adaptive coder's
    context is made of ``na, nb, sg``. Encoding records both codings' symbols; decoding
    reads the one the stream holds. ``state``: (bitpos, x0, x1, pos) of the static
    coder, or (0, code, rng, pos) of the adaptive one. Returns (bin, k, state); the bin
    is ``NO_RESIDUAL`` for a corrupt adaptive stream."""
    bitpos, x0, x1, pos = state
    if decode and adaptive:
        ac, sc = _adaptive_context(na, nb, sg)
        b, x0, x1, pos = _adaptive_bin(data, models, ac, sc, x0, x1, pos)
        if b != NO_RESIDUAL and (b >= MAX_BIN or -b >= MAX_BIN):
            b = NO_RESIDUAL
        return b, k + 1, (bitpos, x0, x1, pos)
    if not decode:
        ac, sc = _adaptive_context(na, nb, sg)
        adx[k] = 4 * ac + sc
    b, k1, bitpos, x0, x1, pos = _code_one(
        decode, v, p, q, c, k, sym, ctx, raw, bitpos, data, x0, x1, pos, table
    )
    if not decode:
        abin[k] = b
    return b, k1, (bitpos, x0, x1, pos)


@kernel(inline=True)
def _walk(x, rec, bn, shape, step, kind, adaptive, decode, sym, ctx, abin, adx, raw, data,
          table, models, given, bins):  # fmt: skip
    """Predict, quantise and rebuild every voxel of ``rec`` (flat, C order of ``shape``):
    level by level for the interpolations (``kind`` 0 linear, 1 cubic), in C order for
    Lorenzo (2: 3-D, 3: 2-D within each slice). ``bn`` (int32, zeroed) takes each voxel's
    bin.

    Encoding (``decode`` 0): reads ``x``, writes the static coding's symbols and contexts
    into ``sym`` and ``ctx`` and its raw bits into ``raw`` (zeroed), and the bins and the
    adaptive coder's contexts into ``abin`` and ``adx`` (:func:`_encode_adaptive` codes
    them); returns the raw bit count. Decoding: reads the bins from ``data``, the static
    rANS stream and ``raw`` or (``adaptive``) the adaptive coder's stream; returns 0, or
    -1 on a corrupt stream. With ``given``: takes the bins, in walk order, from ``bins``
    (decoded beforehand by :func:`_decode_groups`; no contexts, no stream).
    """
    nz, ny, nx = shape
    sty, stz = nx, ny * nx
    z0_ = np.int64(0)
    state = (z0_, z0_, z0_, z0_)
    if decode:
        if adaptive:
            code, rng, pos = open_stream(data)
            state = (z0_, code, rng, np.int64(pos))
        else:
            x0, x1, pos = rans.open_states(data)
            state = (z0_, x0, x1, pos)
    size = data.size
    k = 0
    v = 0.0
    q = step
    if kind >= 2:
        for z in range(nz):
            for y in range(ny):
                prev = 0
                row = z * stz + y * sty
                for xx in range(nx):
                    j = row + xx
                    p = _lorenzo(rec, j, z, y, xx, sty, stz, kind == 2)
                    na = np.int64(0)
                    a = np.int64(0)
                    sg = np.int64(0)
                    if xx:
                        m = abs(np.int64(bn[_U(j - 1)]))
                        na += m
                        a += min(m, 127)
                        sg += bn[_U(j - 1)]
                    if y:
                        m = abs(np.int64(bn[_U(j - sty)]))
                        na += m
                        a += min(m, 127)
                        sg += bn[_U(j - sty)]
                    nb = abs(np.int64(bn[_U(j - stz)])) if kind == 2 and z else np.int64(0)
                    if not decode:
                        v = x[_U(j)]
                    elif adaptive and state[3] > size + 4:
                        return -1
                    if given:
                        b = np.int64(bins[k])
                        k += 1
                    else:
                        b, k, state = _code_any(
                            decode, adaptive, v, p, q, ACT_CONTEXT[a] + prev, na, nb, sg, k,
                            state, sym, ctx, abin, adx, raw, data, table, models,
                        )  # fmt: skip
                    if b == NO_RESIDUAL:
                        return -1
                    rec[_U(j)] = p + np.float64(b) * q
                    bn[_U(j)] = b
                    prev = min(abs(b), N_PREV - 1)
    else:
        top = 0
        while (1 << top) < max(nz, ny, nx):
            top += 1
        for lv in range(top, -1, -1):
            s = 1 << lv if lv < top else 0  # the anchor (0, 0, 0) first, predicted as 0
            for axis in range(3 if s else 1):
                if s == 0:
                    z0 = y0 = xs0 = 0
                    sz = sy = sx = 1
                    nzz, nyy, nxx = 1, 1, 1
                    n = 1
                else:
                    z0 = s if axis == 0 else 0
                    y0 = s if axis == 1 else 0
                    xs0 = s if axis == 2 else 0
                    sz = 2 * s if axis == 0 else s
                    sy = 2 * s if axis <= 1 else s
                    sx = 2 * s
                    nzz, nyy, nxx = nz, ny, nx
                    n = nz if axis == 0 else (ny if axis == 1 else nx)
                off = s * (stz if axis == 0 else (sty if axis == 1 else 1))
                back = sy * sty  # the same pass's voxel one row back: a context
                for z in range(z0, nzz, sz):
                    for y in range(y0, nyy, sy):
                        row = z * stz + y * sty
                        iz = z if axis == 0 else y  # the index along the axis, but x
                        has_back = y >= y0 + sy
                        has_z = axis > 0 and z >= z0 + sz
                        for xx in range(xs0, nxx, sx):
                            j = row + xx
                            na = np.int64(0)
                            a = np.int64(0)
                            nb = np.int64(0)
                            sg = np.int64(0)
                            if s == 0:
                                p = 0.0
                            else:
                                i = xx if axis == 2 else iz
                                p = _predict(rec, j, off, i, s, n, kind)
                                m = abs(np.int64(bn[_U(j - off)]))
                                na += m
                                a += min(m, 127)
                                if i + s < n:
                                    m = abs(np.int64(bn[_U(j + off)]))
                                    na += m
                                    a += min(m, 127)
                                # the same pass's voxels one step back along the
                                # two other axes
                                if has_z:
                                    nb += abs(np.int64(bn[_U(j - sz * stz)]))
                                    sg += bn[_U(j - sz * stz)]
                                if axis != 1 and has_back:
                                    nb += abs(np.int64(bn[_U(j - back)]))
                                    sg += bn[_U(j - back)]
                                if axis != 2 and xx >= xs0 + sx:
                                    nb += abs(np.int64(bn[_U(j - sx)]))
                                    sg += bn[_U(j - sx)]
                            c = ACT_CONTEXT[a]
                            if has_back:
                                c += min(abs(np.int64(bn[_U(j - back)])), N_PREV - 1)
                            if not decode:
                                v = x[_U(j)]
                            elif adaptive and state[3] > size + 4:
                                return -1
                            if given:
                                rec[j] = p + np.float64(bins[k]) * q
                                k += 1
                                continue
                            b, k, state = _code_any(
                                decode, adaptive, v, p, q, c, na, nb, sg, k,
                                state, sym, ctx, abin, adx, raw, data, table, models,
                            )  # fmt: skip
                            if b == NO_RESIDUAL:
                                return -1
                            rec[_U(j)] = p + np.float64(b) * q
                            bn[_U(j)] = b
    bitpos, x0, x1, pos = state
    if given:
        return 0
    if decode:
        if adaptive:
            return 0 if end_status(data, x0, pos) == 0 else -1
        if bitpos > 8 * (raw.size - 8) or not rans.state_ok(data, x0, x1, pos):
            return -1
        return 0
    return bitpos


@kernel(nrt=False)
def _encode_walk(x, rec, bn, shape, step, kind, sym, ctx, abin, adx, raw, no_table, no_models):
    """:func:`_walk` encoding (compiled on its own: the decoding branches fold away)."""
    return _walk(
        x, rec, bn, shape, step, kind, False, False, sym, ctx, abin, adx, raw, raw,
        no_table, no_models, False, bn,
    )  # fmt: skip


@kernel(nrt=False)
def _decode_walk(rec, bn, shape, step, kind, raw, data, table, no_models, no_symbols):
    """:func:`_walk` decoding bins of the static coding (compiled on its own: the
    encoding and adaptive branches fold away)."""
    z = no_symbols
    return _walk(
        rec, rec, bn, shape, step, kind, False, True, z, z, z, z, raw, data, table, no_models,
        False, bn,
    )  # fmt: skip


@kernel(nrt=False)
def _decode_walk_adaptive(rec, bn, shape, step, kind, no_raw, data, no_table, models,
                          no_symbols):  # fmt: skip
    """:func:`_walk` decoding bins of the adaptive coding."""
    z = no_symbols
    return _walk(
        rec, rec, bn, shape, step, kind, True, True, z, z, z, z, no_raw, data, no_table, models,
        False, bn,
    )  # fmt: skip


@kernel(nrt=False)
def _decode_walk_given(rec, bn, shape, step, kind, bins, no_table, no_models):
    """:func:`_walk` with the bins given in walk order (the grouped coding's); the
    stream and symbol arguments are never read: ``bins`` stands in for them."""
    b = bins
    return _walk(rec, rec, bn, shape, step, kind, False, True, b, b, b, b, b, b, no_table,
                 no_models, True, b)  # fmt: skip


@kernel(nrt=False)
def _encode_adaptive(abin, adx, models, out):
    """The bins ``abin`` in the adaptive binary coder (:func:`.predictfit.put_residual`:
    zero flag, sign, unary bit length, two bits below the leading one modelled, the rest
    at one half) in the contexts ``adx`` (4 x context + sign context); the byte count,
    or -1 when ``out`` is too small. ``models``: fresh (:func:`_fresh_models`)."""
    low, rng, pos = open_encoder(out)
    cap = out.size
    for k in range(abin.size):
        if pos + 64 > cap:
            return -1
        a = np.int64(adx[k])  # (int32 arrays: the coder sees int64 as before)
        b = np.int64(abin[k])
        low, rng, pos = put_residual(out, models, a >> 2, a & 3, -1, b, low, rng, pos)
    return finish_stream(out, low, pos)


@kernel(inline=True)
def _lorenzo(rec, j, z, y, x, sty, stz, use_z):
    """The Lorenzo predictor at voxel ``j`` (flat; ``z, y, x``) over the axes with a
    voxel before it (z only when ``use_z``): the sum over the corners of the unit cube
    behind it, signed by parity."""
    if x and y and (z or not use_z):  # the common case first, without the tests
        p = rec[_U(j - 1)] + rec[_U(j - sty)] - rec[_U(j - sty - 1)]
        if use_z:
            u = j - stz
            p = p + rec[_U(u)] - rec[_U(u - 1)] - rec[_U(u - sty)] + rec[_U(u - sty - 1)]
        return p
    p = 0.0
    for corner in range(1, 8):
        dz, dy, dx = corner >> 2, (corner >> 1) & 1, corner & 1
        if (dz and not (use_z and z)) or (dy and not y) or (dx and not x):
            continue
        t = rec[_U(j - dz * stz - dy * sty - dx)]
        p = p + t if (dz + dy + dx) & 1 else p - t
    return p


@kernel
def _group_tokens(sym, n, toks, ctx):
    """The grouped coding's tokens of the ``n`` symbols ``sym`` (walk order) into
    ``toks`` and their contexts into ``ctx`` (each of ``n + n // GROUP + 1``); their
    count."""
    t = 0
    prev = 0
    for g in range(0, n, GROUP):
        end = min(g + GROUP, n)
        top = 0
        for j in range(g, end):
            top |= sym[j]
        c = 64 - np.int64(leading_zeros(np.uint64(top)))  # the class: the OR's bit length
        toks[t] = c
        ctx[t] = prev
        t += 1
        prev = c
        if c:
            k = PACK[c]
            for j in range(g, end, k):
                v = 0
                for i in range(min(k, end - j)):  # past the end: symbols 0
                    v |= sym[j + i] << (c * i)
                toks[t] = v
                ctx[t] = N_CLASS - 1 + c
                t += 1
    return t


@kernel(inline=True)
def _lane_token(lanes, c, table):
    """The next token, in context ``c``, of the lanes' rotation (token ``t`` is lane
    ``t mod 2``'s, its state ``t div 2 mod 2`` of that lane's two): it reads from the
    first lane's first state, then the lanes swap and so do the states within."""
    d0, d1, p0, p1, x0, x1, x2, x3 = lanes
    u, x0, p0 = rans.decode_symbol_bits(d0, x0, p0, c, table, GROUP_BITS)
    return u, (d1, d0, p1, p0, x1, x2, x3, x0)


@kernel(nrt=False)
def _decode_groups(data0, data1, table, raw, bins):
    """The grouped coding's bins into ``bins`` (zeroed; walk order, ``GROUP`` more than
    the voxels) from the two lanes' streams: 0, or -1 on a corrupt stream."""
    a0, a1, p0 = rans.open_states(data0)
    b0, b1, p1 = rans.open_states(data1)
    lanes = (data0, data1, p0, p1, a0, b0, a1, b1)
    n = bins.size - GROUP
    bitpos = np.int64(0)
    prev = np.int64(0)
    for g in range(0, n, GROUP):
        c, lanes = _lane_token(lanes, prev, table)
        if c >= N_CLASS:
            return -1
        prev = c
        if c == 0:
            continue
        cc = N_CLASS - 1 + c
        k = PACK[c]
        if k == 1:
            for j in range(g, min(g + GROUP, n)):
                u, lanes = _lane_token(lanes, cc, table)
                b, bitpos = _symbol_bin(u, raw, bitpos)
                bins[j] = b
            continue
        for j in range(g, min(g + GROUP, n), k):  # bins has GROUP of slack at its end
            v, lanes = _lane_token(lanes, cc, table)
            row = UNPACKED[c, v & 63]  # four bins: those past the token's are 0, so
            for i in range(4):  # writing them over the next token's or group's is safe
                bins[j + i] = row[i]
    d0, d1, p0, p1, x0, x1, x2, x3 = lanes
    # each lane ends where its encoder began (all four states at its start value, so
    # which state is which after the rotation is moot)
    ok = rans.state_ok(d0, x0, x2, p0) and rans.state_ok(d1, x1, x3, p1)
    if bitpos > 8 * (raw.size - 8) or not ok:
        return -1
    return 0


def _grouped(sym: np.ndarray, raw: np.ndarray) -> bytes:
    """The grouped coding (after the header) of the walk's symbols ``sym``."""
    n = sym.size
    toks = np.empty(n + n // GROUP + 1, dtype=np.int64)
    ctx = np.empty_like(toks)
    t = _group_tokens(sym, n, toks, ctx)
    toks, ctx = toks[:t], ctx[:t]
    counts = np.bincount(ctx * N_SYM + toks, minlength=N_GROUP_CTX * N_SYM)
    freq = rans.normalise(counts.reshape(N_GROUP_CTX, N_SYM), GROUP_BITS)
    lane0, lane1 = (rans.encode(toks[i::2], ctx[i::2], freq, GROUP_BITS) for i in (0, 1))
    return (
        put_section(deflate(rans.pack_tables(freq)))
        + put_section(raw.tobytes())
        + put_section(lane0)
        + lane1
    )


def _fresh_models() -> np.ndarray:
    return np.full(N_MODELS, MODEL_INIT, dtype=np.uint32)


def _estimate(sym: np.ndarray, ctx: np.ndarray) -> float:
    """Bits of the static coding of ``sym`` in ``ctx`` (entropy plus about 16 bits per
    table entry): what the encoder compares its choices by."""
    counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM)
    c = counts[counts > 0].astype(np.float64)
    rows = counts.reshape(N_CTX, -1).sum(axis=1).astype(np.float64)
    rows = rows[rows > 0]
    return float((rows * np.log2(rows)).sum() - (c * np.log2(c)).sum() + 16 * c.size)


def _run(g: np.ndarray, step: float, perm, kind: int):
    xt = np.ascontiguousarray(g.transpose(perm))  # contiguous: the walk's loads are cheap
    rec = np.empty_like(xt)
    # symbols (< 84), contexts (< 18), adaptive contexts and bins (|bin| < MAX_BIN = 2^30)
    # fit int32: half the bytes of int64, the kernels' arithmetic as wide as before
    sym, ctx, abin, adx = (np.empty(g.size, dtype=np.int32) for _ in range(4))
    raw = np.zeros(4 * g.size + 16, dtype=np.uint8)
    bn = np.zeros(xt.size, dtype=np.int32)
    no_table, no_models = np.zeros((1, 1), np.uint32), np.zeros(1, np.uint32)
    flat = rec.reshape(-1)
    nbits = _encode_walk(
        xt.reshape(-1), flat, bn, xt.shape, step, kind, sym, ctx, abin, adx, raw,
        no_table, no_models,
    )  # fmt: skip
    return rec.transpose(np.argsort(perm)), sym, ctx, raw[: (nbits + 7) // 8], abin, adx


CODINGS = ("static", "adaptive")
# effort='fast': the grouped coding too, first: the fastest to decode.
CODINGS_FAST = ("grouped", "static", "adaptive")


def _best_each(g: np.ndarray, step: float, tried, codings, few: bool = False) -> dict:
    """Per coding of ``codings``: (bits, axis order, kind byte, reconstruction, coded
    form) of its shortest among ``tried`` ((kind, axis orders) pairs); the static
    coding by its estimated size, the others by their length. With ``few`` the
    adaptive coding is made only for each kind's first axis order and for the walk
    the static estimate ranks first: 5 adaptive codings of TRIED's 12 walks. The
    estimate ranks the static coding, not the adaptive one (at 1e-2 of the range the
    adaptive coding's shortest walk was up to 24 % shorter than the estimate's first's);
    these 5 held the shortest of the 12 within 0.9 % on the 52 cells of
    results/lossy/enc29 (rank.csv)."""
    best = {}
    static_first = None  # (bits, kind, perm) of the static estimate's first
    for kind, perms in tried:
        for perm in perms:
            adaptive = "adaptive" in codings and (not few or perm == PERMS[0])
            found = _walk_codings(g, step, perm, kind, codings, adaptive)
            for name, (bits, k, coded) in found[1].items():
                if name not in best or bits < best[name][0]:
                    best[name] = (bits, perm, k, found[0], coded)
            if "static" in found[1] and (
                static_first is None or found[1]["static"][0] < static_first[0]
            ):
                static_first = (found[1]["static"][0], kind, perm)
            del found  # (not kept: its walk's arrays go before the next walk's are made)
    if few and static_first is not None and "adaptive" in codings and static_first[2] != PERMS[0]:
        _, kind, perm = static_first
        rec, found = _walk_codings(g, step, perm, kind, ("adaptive",), True)
        bits, k, coded = found["adaptive"]
        if bits < best["adaptive"][0]:
            best["adaptive"] = (bits, perm, k, rec, coded)
    return best


def _walk_codings(g, step, perm, kind, codings, adaptive: bool):
    """(reconstruction, {coding: (bits, kind byte, coded form)}) of one walk."""
    rec, sym, ctx, raw, abin, adx = _run(g, step, perm, kind)
    found = {}
    if "static" in codings:
        found["static"] = (_estimate(sym, ctx) + 8 * raw.size, kind, (sym, ctx, raw))
    if "grouped" in codings:
        body = _grouped(sym, raw)
        found["grouped"] = (8 * len(body), kind | GROUPED, body)
    if adaptive:
        body = encode_with_retry(
            lambda out: _encode_adaptive(abin, adx, _fresh_models(), out),
            g.size,
            (2, 20),
            coder="bin",
        )
        found["adaptive"] = (8 * len(body), kind | ADAPTIVE, body)
    return rec, found


def _row_bits(rows: np.ndarray) -> np.ndarray:
    """Bits of each row of counts (last axis: symbols) under its own entropy, plus
    SHARE_TABLE_BITS per symbol it holds."""
    n = rows.sum(axis=-1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        ent = np.where(rows > 0, -rows * np.log2(rows / np.maximum(n, 1)), 0.0)
    return ent.sum(axis=-1) + SHARE_TABLE_BITS * (rows > 0).sum(axis=-1)


def share_tables(counts: np.ndarray) -> np.ndarray:
    """The table index of each context (rows of ``counts``): contexts merged greedily,
    the pair whose merge saves the most bits first (:func:`_row_bits`), while a merge
    saves any. Unused contexts take table 0; tables are numbered in order of their
    first context."""
    counts = np.asarray(counts, dtype=np.float64)
    used = np.flatnonzero(counts.sum(axis=1))
    groups = [[int(c)] for c in used]
    rows = counts[used]
    while len(groups) > 1:
        own = _row_bits(rows)
        gain = _row_bits(rows[:, None, :] + rows[None, :, :]) - own[:, None] - own[None, :]
        gain[np.tril_indices(len(groups))] = np.inf
        i, j = np.unravel_index(int(np.argmin(gain)), gain.shape)
        if gain[i, j] >= 0:
            break
        groups[i] += groups.pop(j)
        rows[i] += rows[j]
        rows = np.delete(rows, j, axis=0)
    out = np.zeros(counts.shape[0], dtype=np.uint8)
    for k, g in enumerate(sorted(groups)):
        out[g] = k
    return out


def _static_section(perm, kind, sym, ctx, raw, counts, table_of=None) -> bytes:
    """The static coding's inner section; with ``table_of`` (:func:`share_tables`) the
    contexts share its tables (kind flag SHARED)."""
    head = b""
    if table_of is not None:
        k = int(table_of.max()) + 1
        merged = np.zeros((k, N_SYM), dtype=np.int64)
        np.add.at(merged, table_of, counts)
        head = bytes([k]) + table_of.tobytes()
        freq, ctx, kind = rans.normalise(merged), table_of[ctx], kind | SHARED
    else:
        freq = rans.normalise(counts)
    return (
        HEADER.pack(*perm, kind)
        + put_section(deflate(head + rans.pack_tables(freq)))
        + put_section(raw.tobytes())
        + rans.encode(sym, ctx, freq)
    )


def _section(best) -> tuple[bytes, np.ndarray]:
    """The inner section and reconstruction of one of :func:`_best_each`'s entries; the
    static coding with tables of its own for each context or, where :func:`encode` made
    it, with shared tables (:func:`share_tables`), whichever is shorter."""
    _, perm, kind, rec, coded = best
    if kind & (ADAPTIVE | GROUPED):
        return HEADER.pack(*perm, kind) + coded, rec
    sym, ctx, raw, *shared = coded
    counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM).reshape(N_CTX, N_SYM)
    inner = _static_section(perm, kind, sym, ctx, raw, counts)
    if shared and len(shared[0]) < len(inner):
        inner = shared[0]
    return inner, rec


def encode(
    g: np.ndarray, step: float, tried=TRIED, codings=CODINGS, min_saving=0.0, few: bool = False
):
    """Code the float64 brick ``g`` (masked voxels filled) with bins of ``step`` (= 2E).
    Returns ``(inner section, reconstruction)`` of the choice among ``tried`` ((kind,
    axis orders) pairs) and ``codings`` of the bins estimated shortest (the static
    one by its entropy, the others by their length). ``codings`` go from the fastest
    to decode to the slowest; each is kept over the faster ones only where it saves
    ``min_saving`` (one share, or one per coding) of the shortest of them's bits.
    ``few``: the adaptive coding tried on fewer walks (:func:`_best_each`)."""
    best = _best_each(g, step, tried, codings, few)
    shares = min_saving if isinstance(min_saving, tuple) else (min_saving,) * len(codings)

    def choose():
        chosen, shortest = None, np.inf
        for name, share in zip(codings, shares, strict=True):
            bits = best[name][0]
            if chosen is None or bits < (1.0 - share) * shortest:
                chosen = best[name]
            shortest = min(shortest, bits)
        return chosen

    chosen = choose()
    if SHARED_TABLES and "static" in best:  # its tables shared, if that is shorter
        bits, perm, k, rec, (sym, ctx, raw) = best["static"]
        counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM).reshape(N_CTX, N_SYM)
        table_of = share_tables(counts)
        if len(np.unique(table_of)) < np.count_nonzero(counts.sum(axis=1)):
            shared = _static_section(perm, k, sym, ctx, raw, counts, table_of)
            was_static = chosen is best["static"]
            best["static"] = (min(bits, 8 * len(shared)), perm, k, rec, (sym, ctx, raw, shared))
            # the choice made again with the shared coding's length; kept where it is the
            # static coding and no longer than the choice made without it (a faster one
            # saves what the rule asks; a slower one was longer): no brick codes longer
            again = choose()
            if again is best["static"] and (
                was_static or len(shared) <= HEADER.size + chosen[0] // 8
            ):
                chosen = again
    return _section(chosen)


def is_adaptive(inner) -> bool:
    """Whether :func:`encode`'s section codes its bins adaptively (kind bit 4)."""
    return bool(inner[HEADER.size - 1] & ADAPTIVE)


def decode(inner, shape: tuple[int, int, int], step: float) -> np.ndarray:
    """The float64 reconstruction of :func:`encode`'s section (before corrections): a
    view in ``shape`` of the walk's array, C-contiguous only when the order is (0, 1, 2)."""
    what = "bounded brick payload (interpolation path)"
    inner = memoryview(inner)
    if len(inner) < HEADER.size:
        raise FormatError(f"{what}: the header is cut short")
    *perm, kind = HEADER.unpack_from(inner, 0)
    adaptive, grouped, shared = bool(kind & ADAPTIVE), bool(kind & GROUPED), bool(kind & SHARED)
    kind &= ~(ADAPTIVE | GROUPED | SHARED)
    if sorted(perm) != [0, 1, 2] or kind > 3 or adaptive + grouped + shared > 1:
        raise FormatError(f"{what}: axis order {perm} or kind {kind} is not one of the known")
    rec = np.empty(tuple(shape[a] for a in perm), dtype=np.float64)
    bn = np.zeros(rec.size, dtype=np.int32)
    flat, z = rec.reshape(-1), np.zeros(1, np.int64)
    if adaptive:
        data = stream_bytes(inner[HEADER.size :], what)
        models = _fresh_models()
        table, raw = np.zeros((1, 1), np.uint32), np.zeros(8, np.uint8)
    else:
        nctx, bits = (N_GROUP_CTX, GROUP_BITS) if grouped else (N_CTX, rans.PROB_BITS)
        body, pos = take_section(inner, HEADER.size, what)
        tables = inflate(body, 2 * (N_SYM + 1) * nctx + 1 + nctx, f"{what} tables")
        table_of, start = None, 0
        if shared:  # K, the table of each context, then K tables
            start = 1 + N_CTX
            if len(tables) < start or not 1 <= tables[0] <= N_CTX:
                raise FormatError(f"{what}: the shared tables' header is cut short or not valid")
            table_of = np.frombuffer(tables[1:start], np.uint8)
            if table_of.max() >= tables[0]:
                raise FormatError(f"{what}: a context names table {table_of.max()} of {tables[0]}")
            nctx = tables[0]
        table, used = rans.unpack_tables(tables[start:], nctx, N_SYM, what, bits)
        if used != len(tables) - start:
            raise FormatError(f"{what}: stray bytes after the rANS tables")
        if table_of is not None:
            table = np.ascontiguousarray(table[table_of])
        raw, pos = take_section(inner, pos, what)
        data = np.frombuffer(bytes(inner[pos:]) + bytes(2), dtype=np.uint8)  # padded: see rans
        raw = np.frombuffer(bytes(raw) + bytes(8), dtype=np.uint8).copy()  # slack: _get_bits
        models = np.zeros(1, np.uint32)
    if grouped:  # the bins first, in a pass of their own; then the walk takes them
        lane0, pos = take_section(inner, pos, what)
        data0 = np.frombuffer(lane0 + bytes(2), dtype=np.uint8)
        data = np.frombuffer(bytes(inner[pos:]) + bytes(2), dtype=np.uint8)
        bins = np.zeros(rec.size + GROUP, dtype=np.int32)  # slack: _decode_groups
        status = _decode_groups(data0, data, table, raw, bins)
        if status == 0:
            status = _decode_walk_given(flat, bn, rec.shape, float(step), kind, bins, table, models)
    else:
        walk = _decode_walk_adaptive if adaptive else _decode_walk
        status = walk(flat, bn, rec.shape, float(step), kind, raw, data, table, models, z)
    if status != 0:
        raise FormatError(f"{what}: the bin stream is corrupt")
    return rec.transpose(np.argsort(perm))
