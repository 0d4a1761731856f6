"""A MEASUREMENT for the next session, not a feature (no format change landed): what a
residual coded with fewer decisions would cost in bits, against today's stream.

Today (``get_residual_mix``) a residual is a zero flag, a sign, the unary bit length
``nb`` of ``|r| - 1`` (nb + 1 decisions, the last ones capped) and up to two mantissa
bits, each a mixed binary decision, then raw bits. The replay here decodes each
stream's decisions in order (the voxels' contexts recorded by a run of the decoder, as
profile.py does) and adds up each decision's ideal cost ``-log2 p`` (p the probability
the coder used: within 0.1 % of the stream's bytes) by kind. Alternatives, their costs
from adaptive models fed the same residuals in the same order:

- ``len1``: the bit length ``nb`` as ONE symbol of an adaptive frequency model (one per
  coding context as today's length models are keyed: ``ctx``, or the low-value class
  and sign), not mixed; zero flag, sign and mantissa bits as today (their mixed costs);
- ``zl1``: the zero flag folded in (symbol 0 for ``r == 0``, else ``1 + nb``, keyed by
  ``ctx`` or the low-value class), then the sign and the mantissa bits as today.

The frequency models: counts start at 1 (24 symbols; nb >= 23 an escape counted at its
bits plus today's length cost), each use adds ``INC``, all halve past ``LIMIT`` (the
usual adaptive multi-symbol model; not tuned). Decisions a residual: today's counted,
the alternatives' (one symbol for the length, or for zero flag and length). ``search``:
the CPU time of the alternative's model work on the decoder side (a linear search of the
cumulative counts for the symbol and the update), ns a residual; the range coder's own
step for a multi-symbol (a division by the total) is NOT included.

    PFD32_DATA=/tmp/ldec36/data PYTHONPATH=. python results/lossless/ldec36/fewer.py ct_head brainsmall --out results/lossless/ldec36/fewer.csv
"""

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pfd32"))  # capture.py, profile.py
import profile as prof  # noqa: E402

import capture  # noqa: E402

from volpack._jit import kernel  # noqa: E402
from volpack.entropy.rangecoder import open_stream  # noqa: E402
from volpack.entropy.rangecoder import pull as _pull  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402
from volpack.volume_codec import residmix as rm  # noqa: E402

NSYM = 24
INC, LIMIT = 24, 1 << 13
NKEY = pf.NCTX + 2 * pf.NLOW


@kernel(inline=True)
def _bit(data, st, code, rng, pos, aux, mx, slot, kind):
    """_get16m_held (clamp off) that also returns the cost of the decision in bits."""
    p1 = st >> 8
    mixed = rm.mixing(mx, p1)
    p, held = rm.mix(p1, aux, mx, slot, kind)  # (only read: the learning is below)
    if not mixed:
        p = p1
    bound = (rng >> 16) * p
    bit = np.int64(code >= bound)
    mask = -bit
    code -= bound & mask
    rng = bound + ((rng - 2 * bound) & mask)
    code, rng, pos = _pull(data, code, rng, pos)
    if mixed:
        rm.learn(aux, mx, slot, p, held, mask, False)
    q = (65536 - p) if bit else p
    return bit, rm.adapted(p1, st & 255, mask), code, rng, pos, -np.log2(q / 65536.0)


@kernel(inline=True)
def _sym(cnt, key, s):
    """Cost of symbol s in the adaptive frequency model ``cnt[key]`` (then updated)."""
    tot = np.int64(0)
    for j in range(NSYM):
        tot += cnt[key, j]
    c = -np.log2(cnt[key, s] / tot)
    cnt[key, s] += INC
    if tot + INC > LIMIT:
        for j in range(NSYM):
            cnt[key, j] = (cnt[key, j] + 1) >> 1
    return c


@kernel(nrt=False)
def _replay(data, mk, cx, n, models, aux, cost, syms, c1, c2):
    """cost[0..4]: today's zero flags, signs, lengths, mantissa bits, raw bits; cost[5]:
    len1's lengths; cost[6]: zl1's zero-and-length symbols; cost[7] decisions today,
    cost[8] of them length decisions; cost[9] nonzero residuals.
    ``syms``: per coded residual, (key of len1, nb or -1 for a zero, key of zl1)."""
    code, rng, pos = open_stream(data)
    m = 0
    for i in range(n):
        if mk[i]:
            continue
        b = 7 * i
        ctx, sctx, q = cx[b], cx[b + 1], cx[b + 2]
        mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
        kz, st = pf._zero_state(models, ctx, sctx, q)
        sz = rm.S_ZERO + (sctx & (pf.NFRAC - 1))
        bit, models[np.uint64(kz)], code, rng, pos, c = _bit(data, st, code, rng, pos, aux, mx, sz, 0)
        cost[0] += c
        cost[7] += 1
        kzl = ctx if q < 0 else pf.NCTX + q
        if bit == 0:
            cost[6] += _sym(c2, kzl, 0)
            syms[m, 0], syms[m, 1], syms[m, 2] = -1, -1, kzl
            m += 1
            continue
        ks = pf._sign_model(ctx, sctx, q)
        st = np.int64(models[np.uint64(ks)])
        neg, models[np.uint64(ks)], code, rng, pos, c = _bit(data, st, code, rng, pos, aux, mx, rm.S_SIGN + sctx, 1)
        cost[1] += c
        cost[7] += 1
        cost[9] += 1
        k0 = pf._len_models(ctx, q, neg)
        nb = 0
        lc = 0.0
        while nb < pf.NLEN - 1:
            sl, kind = pf._len_slot(nb)
            st = np.int64(models[np.uint64(k0 + nb)])
            bit, models[np.uint64(k0 + nb)], code, rng, pos, c = _bit(data, st, code, rng, pos, aux, mx, sl, kind)
            lc += c
            cost[7] += 1
            cost[8] += 1
            if bit == 0:
                break
            nb += 1
        cost[2] += lc
        kl = ctx if q < 0 else pf.NCTX + 2 * q + neg
        s = min(nb, NSYM - 1)
        cost[5] += _sym(c1, kl, s) + (lc if nb >= NSYM - 1 else 0.0)
        cost[6] += _sym(c2, kzl, min(nb + 1, NSYM - 1)) + (lc if nb + 1 >= NSYM - 1 else 0.0)
        syms[m, 0], syms[m, 1], syms[m, 2] = kl, s, kzl
        m += 1
        u = np.int64(1 if nb >= 1 else 0)
        nm = min(nb - 1, 2)
        prefix = 1
        for jm in range(nm):
            km = pf._mant_model(nb, prefix, ctx)
            sl = pf._mant_slot(nb, prefix)
            st = np.int64(models[np.uint64(km)])
            bit, models[np.uint64(km)], code, rng, pos, c = _bit(data, st, code, rng, pos, aux, mx, sl, 14 + jm)
            cost[3] += c
            cost[7] += 1
            prefix = 2 * prefix + bit
            u = (u << 1) | bit
        cost[4] += max(nb - 1 - max(nm, 0), 0)
        r, code, rng, pos = pf._low_bits(data, u, nb, nm, neg, code, rng, pos)
    return m


@kernel(nrt=False)
def _search(syms, m, cnt, which):
    """The decoder-side work of the alternative's symbols: per symbol, the cumulative
    counts searched for it (from a target inside its interval, as a decoder would have
    one) and the model updated. ``which`` 0: len1 (skips zeros), 1: zl1."""
    acc = np.int64(0)
    for i in range(m):
        if which == 0:
            if syms[i, 1] < 0:
                continue
            key, s = syms[i, 0], syms[i, 1]
        else:
            key, s = syms[i, 2], syms[i, 1] + 1
            s = min(s, NSYM - 1)
        tot = np.int64(0)
        below = np.int64(0)
        for j in range(NSYM):
            if j == s:
                below = tot
            tot += cnt[key, j]
        target = below + (cnt[key, s] >> 1)
        j = 0
        cum = cnt[key, 0]
        while cum <= target:
            j += 1
            cum += cnt[key, j]
        acc += j
        cnt[key, j] += INC
        if tot + INC > LIMIT:
            for k in range(NSYM):
                cnt[key, k] = (cnt[key, k] + 1) >> 1
    return acc


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("items", nargs="+")
    ap.add_argument("--streams", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    rows = []
    for name in args.items:
        cost = np.zeros(10)
        res = 0
        tsearch = [0.0, 0.0]
        for item in capture.streams(name)[: args.streams]:
            a = prof.kernel_args(item)
            n = int(np.prod(item[1]))
            v = np.empty(n, np.int64)
            cx = np.zeros(7 * n, np.int64)
            prof._record(*a, v, *pf._workspace(item[1])[:8], cx)
            ws = pf._workspace(item[1])
            syms = np.zeros((n, 3), np.int64)
            c1 = np.ones((NKEY, NSYM), np.int64)
            c2 = np.ones((NKEY, NSYM), np.int64)
            m = _replay(a[0], a[1], cx, n, ws[5], ws[6], cost, syms, c1, c2)
            res += m
            for w in (0, 1):
                best = np.inf
                for _ in range(args.repeat):
                    cnt = np.ones((NKEY, NSYM), np.int64)
                    t = time.process_time()
                    _search(syms, m, cnt, w)
                    best = min(best, time.process_time() - t)
                tsearch[w] += best
        today = cost[:5].sum()
        len1 = today - cost[2] + cost[5]
        zl1 = today - cost[0] - cost[2] + cost[6]
        # decisions: today's; len1 drops the length decisions for one symbol per nonzero
        # residual; zl1 drops the zero flags and lengths for one symbol per residual
        row = {"item": name, "residuals": res, "bits_today": round(today / res, 4),
               "bits_len1": round(len1 / res, 4), "bits_zl1": round(zl1 / res, 4),
               "ratio_len1": round(today / len1, 4), "ratio_zl1": round(today / zl1, 4),
               "zero_bits": round(cost[0] / res, 4), "sign_bits": round(cost[1] / res, 4),
               "len_bits": round(cost[2] / res, 4), "mant_bits": round(cost[3] / res, 4),
               "raw_bits": round(cost[4] / res, 4), "decisions_today": round(cost[7] / res, 3),
               "decisions_len1": round((cost[7] - cost[8] + cost[9]) / res, 3),
               "decisions_zl1": round((cost[7] - cost[8]) / res, 3),  # (the zero flag becomes the symbol)
               "search_len1_ns": round(1e9 * tsearch[0] / res, 2), "search_zl1_ns": round(1e9 * tsearch[1] / res, 2)}
        print(row, flush=True)
        rows.append(row)
    if args.out:
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
