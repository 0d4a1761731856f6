"""The work per residual of predictfit's default decoder, counted on capture.py's streams:
for each magnitude class of the residual (0, 1, 2-3, 4-7, 8-15, 16+), the share of the
coded voxels, the binary decisions a residual, how many of them are mixed (model 1 not
sure: the mix of four estimates, four weight steps, three more model updates) and the
bits coded at one half. The decisions are replayed in the order ``get_residual_mix``
takes them (the voxels' contexts recorded by a run of the decoder, as profile.py does).

    PFD32_DATA=/tmp/ldec36/data PYTHONPATH=. python results/lossless/ldec36/count.py ct_head brainsmall --out results/lossless/ldec36/count_base.csv
"""

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pfd32"))  # capture.py, profile.py
import profile as prof  # noqa: E402

import capture  # noqa: E402

from volpack._jit import kernel  # noqa: E402
from volpack.entropy.rangecoder import open_stream  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402
from volpack.volume_codec import residmix  # noqa: E402

NCLASS = 6


@kernel(inline=True)
def _one(data, models, k, code, rng, pos, aux, mx, slot, kind, cnt, c):
    st = np.int64(models[np.uint64(k)])
    cnt[c, 1] += 1
    if residmix.mixing(mx, st >> 8):
        cnt[c, 2] += 1
    bit, models[np.uint64(k)], code, rng, pos = pf._get16m_held(
        data, st, code, rng, pos, aux, mx, slot, kind, True
    )
    return bit, code, rng, pos


@kernel(nrt=False)
def _count(data, mk, cx, n, models, aux, cnt):
    """Replays each voxel's decisions, counting into ``cnt[class]``: voxels, decisions,
    mixed decisions, raw bits. The class is known only at the end, so the counts go to
    a scratch row (NCLASS) and are moved over."""
    code, rng, pos = open_stream(data)
    for i in range(n):
        if mk[i]:
            continue
        b = 7 * i
        ctx, sctx, q = cx[b], cx[b + 1], cx[b + 2]
        mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
        s = NCLASS
        for j in range(4):
            cnt[s, j] = 0
        kz, st = pf._zero_state(models, ctx, sctx, q)
        sz = residmix.S_ZERO + (sctx & (pf.NFRAC - 1))
        cnt[s, 1] += 1
        if residmix.mixing(mx, st >> 8):
            cnt[s, 2] += 1
        bit, models[np.uint64(kz)], code, rng, pos = pf._get16m_held(data, st, code, rng, pos, aux, mx, sz, 0, True)
        res = np.int64(0)
        if bit:
            ks = pf._sign_model(ctx, sctx, q)
            neg, code, rng, pos = _one(data, models, ks, code, rng, pos, aux, mx, residmix.S_SIGN + sctx, 1, cnt, s)
            k0 = pf._len_models(ctx, q, neg)
            nb = 0
            while nb < pf.NLEN - 1:
                sl, kind = pf._len_slot(nb)
                bit, code, rng, pos = _one(data, models, k0 + nb, code, rng, pos, aux, mx, sl, kind, cnt, s)
                if bit == 0:
                    break
                nb += 1
            u = np.int64(1 if nb >= 1 else 0)
            nm = min(nb - 1, 2)
            prefix = 1
            for jm in range(nm):
                km = pf._mant_model(nb, prefix, ctx)
                sl = pf._mant_slot(nb, prefix)
                bit, code, rng, pos = _one(data, models, km, code, rng, pos, aux, mx, sl, 14 + jm, cnt, s)
                prefix = 2 * prefix + bit
                u = (u << 1) | bit
            cnt[s, 3] += max(nb - 1 - max(nm, 0), 0)
            res, code, rng, pos = pf._low_bits(data, u, nb, nm, neg, code, rng, pos)
        a = abs(res)
        c = min(pf.bitlen(a), NCLASS - 1)
        cnt[c, 0] += 1
        for j in range(1, 4):
            cnt[c, j] += cnt[s, j]
    return 0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("items", nargs="+")
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    rows = []
    names = ["0", "1", "2-3", "4-7", "8-15", "16+"]
    for name in args.items:
        tot = np.zeros((NCLASS + 1, 4), np.int64)
        for item in capture.streams(name):
            a = prof.kernel_args(item)
            n = int(np.prod(item[1]))
            v = np.empty(n, np.int64)
            cx = np.zeros(7 * n, np.int64)
            prof._record(*a, v, *pf._workspace(item[1])[:8], cx)
            ws = pf._workspace(item[1])
            cnt = np.zeros((NCLASS + 1, 4), np.int64)
            _count(a[0], a[1], cx, n, ws[5], ws[6], cnt)
            tot += cnt
        vox = tot[:NCLASS, 0].sum()
        for c in range(NCLASS):
            k = tot[c]
            row = {"item": name, "class": names[c], "share": round(k[0] / vox, 4),
                   "decisions": round(k[1] / max(k[0], 1), 2), "mixed": round(k[2] / max(k[0], 1), 2),
                   "raw_bits": round(k[3] / max(k[0], 1), 2)}
            rows.append(row)
        k = tot[:NCLASS].sum(0)
        row = {"item": name, "class": "all", "share": 1.0, "decisions": round(k[1] / vox, 2),
               "mixed": round(k[2] / vox, 2), "raw_bits": round(k[3] / vox, 2)}
        rows.append(row)
        print(row, flush=True)
    if args.out:
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    print("| item | class | share | decisions | mixed | raw bits |\n|---|---|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['item']} | {r['class']} | {r['share']} | {r['decisions']} | {r['mixed']} | {r['raw_bits']} |")


if __name__ == "__main__":
    main()
