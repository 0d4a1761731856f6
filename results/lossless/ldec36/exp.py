"""Variants of the mixed residual decoder, timed in ONE process on the residual decisions
alone (each voxel's contexts recorded by a run of the decoder, as profile.py's
``entropy`` stage): the base's ``get_residual_mix`` against copies with one change each.
Every variant must give the same residuals (checksum). ns per coded voxel, best of
``--repeat`` CPU times, variants taking turns.

    PFD32_DATA=/tmp/ldec36/data PYTHONPATH=. python results/lossless/ldec36/exp.py ct_head brainsmall --repeat 5
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pfd32"))  # capture.py, profile.py
import profile as prof  # noqa: E402

import capture  # noqa: E402

from volpack._jit import kernel  # noqa: E402
from volpack.entropy.rangecoder import TOP, open_stream  # noqa: E402
from volpack.entropy.rangecoder import pull as _pull  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402
from volpack.volume_codec import residmix as rm  # noqa: E402

ST16 = rm.STRETCH.astype(np.int16)
SQ16 = rm.SQUASH.astype(np.uint16)
NCAP = rm.NCAP
RATE8 = rm.RATE.astype(np.uint8)


# ---- pieces with one change each --------------------------------------------------------
@kernel(inline=True)
def pull2(data, code, rng, pos):
    """pull with its loop as two tests (a decision leaves rng >= 2^8: two bytes at most)."""
    if rng < TOP:
        rng <<= 8
        byte = np.int64(data[np.uint64(pos)]) if pos < data.size else 0
        code = ((code << 8) | byte) & 0xFFFFFFFF
        pos += 1
        if rng < TOP:
            rng <<= 8
            byte = np.int64(data[np.uint64(pos)]) if pos < data.size else 0
            code = ((code << 8) | byte) & 0xFFFFFFFF
            pos += 1
    return code, rng, pos


@kernel(inline=True)
def adapted_c(p, n, mask):
    """rm.adapted with the rates a uint8 table."""
    r = np.int64(RATE8[np.uint64(n)])
    g = (65536 - p) >> r
    p += g - ((g + (p >> r)) & mask)
    return (p << 8) | (n + np.int64(n < NCAP))


@kernel(inline=True)
def adapted_s(p, n, mask):
    """adapted_c as a select between the two moves (the same state)."""
    r = np.int64(RATE8[np.uint64(n)])
    up = p + ((65536 - p) >> r)
    down = p - (p >> r)
    p = down if mask else up
    return (p << 8) | (n + np.int64(n < NCAP))


@kernel(inline=True)
def learn_s(aux, mx, slot, p, held, mask):
    s1, s2, s3, s4, wb, w1, w2, w3, w4, t2, t3, t4 = held
    e = ((mask + 1) << 16) - p
    aux[np.uint64(wb)] = w1 + ((s1 * e) >> 16)
    aux[np.uint64(wb + 1)] = w2 + ((s2 * e) >> 16)
    aux[np.uint64(wb + 2)] = w3 + ((s3 * e) >> 16)
    aux[np.uint64(wb + 3)] = w4 + ((s4 * e) >> 16)
    aux[np.uint64(mx[0] + slot)] = adapted_s(t2 >> 8, t2 & 255, mask)
    aux[np.uint64(mx[1] + slot)] = adapted_s(t3 >> 8, t3 & 255, mask)
    aux[np.uint64(mx[2] + slot)] = adapted_s(t4 >> 8, t4 & 255, mask)


@kernel(inline=True)
def mix16(p1, aux, mx, slot, kind):
    s1 = np.int64(ST16[np.uint64(p1 >> 4)])
    t2 = np.int64(aux[np.uint64(mx[0] + slot)])
    t3 = np.int64(aux[np.uint64(mx[1] + slot)])
    t4 = np.int64(aux[np.uint64(mx[2] + slot)])
    s2 = np.int64(ST16[np.uint64(t2 >> 12)])
    s3 = np.int64(ST16[np.uint64(t3 >> 12)])
    s4 = np.int64(ST16[np.uint64(t4 >> 12)])
    wb = rm.W_BASE + (kind * rm.NGROUP + mx[3]) * rm.NIN
    w1 = np.int64(aux[np.uint64(wb)])
    w2 = np.int64(aux[np.uint64(wb + 1)])
    w3 = np.int64(aux[np.uint64(wb + 2)])
    w4 = np.int64(aux[np.uint64(wb + 3)])
    dot = w1 * s1 + w2 * s2 + w3 * s3 + w4 * s4
    t = min(max(dot >> 16, -rm.ST_MAX), rm.ST_MAX)
    p = np.int64(SQ16[np.uint64(t + rm.ST_MAX)])
    return p, (s1, s2, s3, s4, wb, w1, w2, w3, w4, t2, t3, t4)


@kernel(inline=True)
def learn_c(aux, mx, slot, p, held, mask):
    s1, s2, s3, s4, wb, w1, w2, w3, w4, t2, t3, t4 = held
    e = ((mask + 1) << 16) - p
    aux[np.uint64(wb)] = w1 + ((s1 * e) >> 16)
    aux[np.uint64(wb + 1)] = w2 + ((s2 * e) >> 16)
    aux[np.uint64(wb + 2)] = w3 + ((s3 * e) >> 16)
    aux[np.uint64(wb + 3)] = w4 + ((s4 * e) >> 16)
    aux[np.uint64(mx[0] + slot)] = adapted_c(t2 >> 8, t2 & 255, mask)
    aux[np.uint64(mx[1] + slot)] = adapted_c(t3 >> 8, t3 & 255, mask)
    aux[np.uint64(mx[2] + slot)] = adapted_c(t4 >> 8, t4 & 255, mask)


# ---- a generic mixed decision, its pieces chosen by constants -----------------------------
@kernel(inline=True)
def dec(data, st, code, rng, pos, aux, mx, slot, kind, V):
    """_get16m_held (clamp off) with V = (pull2, uint8 rates, 16-bit tables, the model update as a select)."""
    p1 = st >> 8
    if not rm.mixing(mx, p1):
        p = p1
        bound = (rng >> 16) * p
        bit = np.int64(code >= bound)
        mask = -bit
        code -= bound & mask
        rng = bound + ((rng - 2 * bound) & mask)
        if V[0]:
            code, rng, pos = pull2(data, code, rng, pos)
        else:
            code, rng, pos = _pull(data, code, rng, pos)
        if V[3]:
            new = adapted_s(p1, st & 255, mask)
        elif V[1]:
            new = adapted_c(p1, st & 255, mask)
        else:
            new = rm.adapted(p1, st & 255, mask)
        return bit, new, code, rng, pos
    if V[2]:
        p, held = mix16(p1, aux, mx, slot, kind)
    else:
        p, held = rm.mix(p1, aux, mx, slot, kind)
    bound = (rng >> 16) * p
    bit = np.int64(code >= bound)
    mask = -bit
    code -= bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    if V[0]:
        code, rng, pos = pull2(data, code, rng, pos)
    else:
        code, rng, pos = _pull(data, code, rng, pos)
    if V[3]:
        learn_s(aux, mx, slot, p, held, mask)
        new = adapted_s(p1, st & 255, mask)
    elif V[1]:
        learn_c(aux, mx, slot, p, held, mask)
        new = adapted_c(p1, st & 255, mask)
    else:
        rm.learn(aux, mx, slot, p, held, mask, False)
        new = rm.adapted(p1, st & 255, mask)
    return bit, new, code, rng, pos


@kernel(inline=True)
def dec_m(data, models, k, code, rng, pos, aux, mx, slot, kind, V):
    bit, models[np.uint64(k)], code, rng, pos = dec(
        data, np.int64(models[np.uint64(k)]), code, rng, pos, aux, mx, slot, kind, V
    )
    return bit, code, rng, pos


@kernel(inline=True)
def residual(data, models, ctx, sctx, q, code, rng, pos, aux, mx, V):
    kz, st = pf._zero_state(models, ctx, sctx, q)
    sz = rm.S_ZERO + (sctx & (pf.NFRAC - 1))
    bit, models[np.uint64(kz)], code, rng, pos = dec(data, st, code, rng, pos, aux, mx, sz, 0, V)
    if bit == 0:
        return np.int64(0), code, rng, pos
    ks = pf._sign_model(ctx, sctx, q)
    neg, code, rng, pos = dec_m(data, models, ks, code, rng, pos, aux, mx, rm.S_SIGN + sctx, 1, V)
    k0 = pf._len_models(ctx, q, neg)
    nb = 0
    while nb < pf.NLEN - 1:
        sl, kind = pf._len_slot(nb)
        bit, code, rng, pos = dec_m(data, models, k0 + nb, code, rng, pos, aux, mx, sl, kind, V)
        if bit == 0:
            break
        nb += 1
    if nb > 62:
        return pf.NO_RESIDUAL, code, rng, pos
    u = np.int64(1 if nb >= 1 else 0)
    nm = min(nb - 1, 2)
    prefix = 1
    for jm in range(nm):
        km = pf._mant_model(nb, prefix, ctx)
        sl = pf._mant_slot(nb, prefix)
        bit, code, rng, pos = dec_m(data, models, km, code, rng, pos, aux, mx, sl, 14 + jm, V)
        prefix = 2 * prefix + bit
        u = (u << 1) | bit
    return pf._low_bits(data, u, nb, nm, neg, code, rng, pos)


def make(V):
    @kernel(nrt=False)
    def run(data, mk, cx, n, models, aux):
        code, rng, pos = open_stream(data)
        acc = np.int64(0)
        for i in range(n):
            if mk[i]:
                continue
            b = 7 * i
            mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
            res, code, rng, pos = residual(data, models, cx[b], cx[b + 1], cx[b + 2], code, rng, pos, aux, mx, V)
            acc = acc * 31 + res
        return acc

    return run


@kernel(nrt=False)
def run_base(data, mk, cx, n, models, aux):
    code, rng, pos = open_stream(data)
    acc = np.int64(0)
    for i in range(n):
        if mk[i]:
            continue
        b = 7 * i
        mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
        res, code, rng, pos = pf.get_residual_mix(data, models, cx[b], cx[b + 1], cx[b + 2], code, rng, pos,
                                                  aux, mx, False)
        acc = acc * 31 + res
    return acc


@kernel(inline=True)
def residual_oneloop(data, models, ctx, sctx, q, code, rng, pos, aux, mx):
    """get_residual_mix with the length and mantissa decisions in one loop (one copy of
    the mixed decision for both): the same decisions in the same order."""
    kz, st = pf._zero_state(models, ctx, sctx, q)
    sz = rm.S_ZERO + (sctx & (pf.NFRAC - 1))
    bit, models[np.uint64(kz)], code, rng, pos = pf._get16m_held(data, st, code, rng, pos, aux, mx, sz, 0, False)
    if bit == 0:
        return np.int64(0), code, rng, pos
    ks = pf._sign_model(ctx, sctx, q)
    neg, code, rng, pos = pf._get16m(data, models, ks, code, rng, pos, aux, mx, rm.S_SIGN + sctx, 1, False)
    k0 = pf._len_models(ctx, q, neg)
    nb = 0
    nm = -1  # -1: in the length; then the mantissa bits left
    jm = 0
    prefix = 1
    u = np.int64(0)
    k = k0
    sl, kind = pf._len_slot(0)
    while True:
        bit, code, rng, pos = pf._get16m(data, models, k, code, rng, pos, aux, mx, sl, kind, False)
        if nm < 0:
            if bit != 0 and nb < pf.NLEN - 2:
                nb += 1
                k = k0 + nb
                sl, kind = pf._len_slot(nb)
                continue
            nb += bit
            if nb > 62:
                return pf.NO_RESIDUAL, code, rng, pos
            u = np.int64(1 if nb >= 1 else 0)
            nm = min(nb - 1, 2)
        else:
            prefix = 2 * prefix + bit
            u = (u << 1) | bit
            jm += 1
        if jm >= nm:
            break
        k = pf._mant_model(nb, prefix, ctx)
        sl = pf._mant_slot(nb, prefix)
        kind = 14 + jm
    return pf._low_bits(data, u, nb, nm, neg, code, rng, pos)


@kernel(nrt=False)
def run_oneloop(data, mk, cx, n, models, aux):
    code, rng, pos = open_stream(data)
    acc = np.int64(0)
    for i in range(n):
        if mk[i]:
            continue
        b = 7 * i
        mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
        res, code, rng, pos = residual_oneloop(data, models, cx[b], cx[b + 1], cx[b + 2], code, rng, pos, aux, mx)
        acc = acc * 31 + res
    return acc


VARIANTS = {"base": run_base, "generic": make((False, False, False, False)), "pull2": make((True, False, False, False)),
            "rate": make((False, True, False, False)), "tab16": make((False, False, True, False)), "t16r8": make((False, True, True, False)), "sel": make((False, True, True, True)),
            "all3": make((True, True, True, False)), "oneloop": run_oneloop}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("items", nargs="+")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", default="")
    ap.add_argument("--streams", type=int, default=12, help="the first N streams of an item (memory)")
    args = ap.parse_args()
    names = [v for v in VARIANTS if not args.only or v in args.only.split(",") or v == "base"]
    for name in args.items:
        jobs = []
        for item in capture.streams(name)[: args.streams]:
            a = prof.kernel_args(item)
            n = int(np.prod(item[1]))
            v = np.empty(n, np.int64)
            cx = np.zeros(7 * n, np.int64)
            prof._record(*a, v, *pf._workspace(item[1])[:8], cx)
            jobs.append((a[0], a[1], cx, n, item[1], int(n - a[1].sum())))
        coded = sum(j[5] for j in jobs)
        best = {k: np.inf for k in names}
        sums = {}
        for r in range(args.repeat):
            order = names if r % 2 == 0 else names[::-1]
            for k in order:
                f = VARIANTS[k]
                wss = [pf._workspace(j[4])[5:7] for j in jobs]
                t = time.process_time()
                s = [f(j[0], j[1], j[2], j[3], w[0], w[1]) for j, w in zip(jobs, wss)]
                best[k] = min(best[k], time.process_time() - t)
                sums[k] = s
        same = all(sums[k] == sums["base"] for k in names)
        b = best["base"]
        print(name, "same" if same else "DIFFERENT", " ".join(
            f"{k} {1e9 * best[k] / coded:.1f}ns x{b / best[k]:.3f}" for k in names), flush=True)


if __name__ == "__main__":
    main()
