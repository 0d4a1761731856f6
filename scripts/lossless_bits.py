"""Where a volume's bits go in the default lossless codec, and what candidate changes
to its predict2 stream would save (issue 20, branch lossless17).

For each volume coded as one brick (the default for integer volumes of at most 2^21
voxels): the container's bytes, each candidate payload the encoder tries and the one
it keeps, and the kept predict2 stream split into its parts: the side information
(range or palette, mask section, the fitted predictor's thresholds and weights) and the
residuals' cost by decision (zero flags, signs, unary bit lengths, modelled mantissa
bits, plain bits), from a copy of the encoder's kernel that adds ``-log2 p`` of every
decision instead of coding it (it reproduces a version-7 stream's length to a few
bytes; it has no mix and no local fit, so against the version-8 default it reads about
1-2 % long: nibabel T1 51,664 B estimated for a 50,809 B payload).

The same copy takes any causal neighbourhood and any number of gradient classes for
the fitted predictor, so candidates are measured by their real cost (blend, bias,
contexts and adaptive models unchanged), not by a proxy:

    python scripts/lossless_bits.py brainsmall mri_dipy_s0 mri_nibabel_t1 mri_epi_nibabel
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

from volpack import api  # noqa: E402
from volpack._jit import kernel  # noqa: E402
from volpack.volume_codec import bgmask, lossless  # noqa: E402
from volpack.volume_codec import palette as pal  # noqa: E402
from volpack.volume_codec import predict as pr  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402

PARTS = ("zero", "sign", "length", "mantissa", "plain")


@kernel(inline=True)
def _cost16(models, k, bit, cost, part):
    st = np.int64(models[np.uint64(k)])
    p = st >> 8
    q = p if bit == 0 else 65536 - p
    cost[part] -= np.log2(q / 65536.0)
    models[np.uint64(k)] = pf._adapted(p, st & 255, -np.int64(bit))


@kernel(inline=True)
def _cost_residual(models, ctx, sctx, q, r, cost, ksign):
    kz = pf._zero_model(ctx, sctx) if q < 0 else pf.M_LOWZ + q * pf.NFRAC + (sctx & (pf.NFRAC - 1))
    _cost16(models, kz, np.int64(r != 0), cost, 0)
    if r == 0:
        return
    neg = np.int64(r < 0)
    _cost16(models, pf._sign_model(ctx, sctx, q) if ksign < 0 or q >= 0 else ksign, neg, cost, 1)
    u = abs(r) - 1
    nb = pr.bitlen(u)
    k0 = pf._len_models(ctx, q, neg)
    for j in range(min(nb + 1, pr.NLEN - 1)):
        _cost16(models, k0 + j, np.int64(nb > j), cost, 2)
    nm = min(nb - 1, 2)
    prefix = 1
    for jm in range(nm):
        bit = (u >> (nb - 2 - jm)) & 1
        _cost16(models, pf._mant_model(nb, prefix, ctx), bit, cost, 3)
        prefix = 2 * prefix + bit
    cost[4] += max(nb - 1 - max(nm, 0), 0)


@kernel(inline=True)
def _fitted_any(v, cf, c, i, lin, nf):
    t = np.int64(0)
    for j in range(nf):
        t += cf[np.uint64(c + j)] * v[np.uint64(i - lin[j])]
    return (t + (1 << (pf.CF_BITS - 4))) >> (pf.CF_BITS - 3)


@kernel(nrt=False)
def _cost_kernel(v, mk, cf, th, lin, margin, gmode, tex, coarse, sgn, extra, shape, hi, nlow, cost, err, perr, bias_sum, bias_cnt, bias, models):
    """predictfit's encoder with the fitted predictor over the neighbours at linear steps
    back ``lin`` (used where ``margin`` = (z, y, x back, x ahead) allows, else U + N - UN),
    ``th.size + 1`` gradient classes (``gmode`` 1: the in-slice gradient only)."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    nf = lin.size
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                r = cur + y * nx + x
                if mk[np.uint64(i)]:
                    perr[np.uint64(r * 8 + 6)] = 0
                    held = pf._skip(err, perr, r, v[np.uint64(i)])
                    i += 1
                    continue
                W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5 = pf._gather(
                    v, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, held
                )
                h8 = 8 * hi
                q0 = min(max(8 * (W + N - NW), 0), h8)
                q1 = min(max(8 * (U + W - UW), 0), h8)
                if z >= margin[0] and y >= margin[1] and x >= margin[2] and x + margin[3] < nx and y + 1 < ny:
                    if gmode == 1:
                        g = abs(W - NW) + abs(N - NW) + abs(N - NE)
                    else:
                        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
                    c = np.int64(0)
                    for k in range(th.size):
                        c += np.int64(g > th[k])
                    q2 = min(max(_fitted_any(v, cf, c * nf, i, lin, nf), 0), h8)
                else:
                    q2 = min(max(8 * (U + N - UN), 0), h8)
                q3 = min(max(8 * (W + N + U - NW - UW - UN + UNW), 0), h8)
                q4 = 8 * U
                q5 = 4 * (W + NE)
                q6 = np.int64(0)
                w6 = np.int64(0)
                inner = extra > 0 and y >= 2 and x >= 1 and x + 1 < nx and z >= 1
                if inner:
                    if extra == 1:
                        q6 = min(max(8 * (W + NE - N), 0), h8)
                    elif extra == 2:
                        q6 = 8 * max(min(W, N), min(max(W, N), W + N - NW))
                    else:
                        NN = v[np.uint64(i - 2 * nx)]
                        NNE = v[np.uint64(i - 2 * nx + 1)]
                        q6 = min(max(8 * (N + NE - NNE), 0), h8)
                    s6 = (perr[np.uint64((r - 1) * 8 + 6)] + perr[np.uint64((r - nx) * 8 + 6)]
                          + perr[np.uint64((r - nx - 1) * 8 + 6)] + perr[np.uint64((r - nx + 1) * 8 + 6)]
                          + perr[np.uint64((r - cur + prev) * 8 + 6)])
                    w6 = pf._weight2(s6)
                act = act2 >> 1
                if coarse < 0:  # the local gradient in the activity too
                    gg = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
                    if sgn == 3 and x >= 2 and y >= 2:
                        act2 += abs(err[np.uint64(r - 2)]) + abs(err[np.uint64(r - 2 * nx)])
                    act = (act2 + gg) >> 1 if coarse == -1 else ((act2 + (gg >> 1)) >> 1 if coarse == -2 else (act2 + 2 * gg) >> 1)
                w0 = pf._weight2(s0)
                w1 = pf._weight2(s1)
                w2 = pf._weight2(s2)
                w3 = pf._weight2(s3)
                w4 = pf._weight2(s4)
                w5 = pf._weight2(s5)
                den = w0 + w1 + w2 + w3 + w4 + w5 + w6
                rden = 1.0 / np.float64(den)
                num = w0 * q0 + w1 * q1 + w2 * q2 + w3 * q3 + w4 * q4 + w5 * q5 + w6 * q6
                ctx = pr.context(act, (max(q0, q1, q2, q3, q4, q5) - min(q0, q1, q2, q3, q4, q5)) >> 3)
                if coarse > 0:
                    ctx = ((ctx // 3) >> coarse) * 3 + ctx % 3
                p0 = pr.floor_div_recip(num + (den >> 1), den, rden)
                bctx = ctx
                if tex > 0:
                    ref = q2 if tex == 3 else p0
                    t = (np.int64(8 * W > ref) + 2 * np.int64(8 * N > ref) + 4 * np.int64(8 * U > ref)
                         + 8 * np.int64(8 * NE > ref))
                    if tex == 4:
                        t += 16 * np.int64(8 * NW > ref) + 32 * np.int64(8 * UN > ref)
                    cb = ctx if tex == 1 else (ctx // 3 if tex == 5 else (ctx // 6 if sgn == 4 else ctx // 12))
                    bctx = cb + pr.NCTX * t
                p8 = p0 + bias[np.uint64(bctx)]
                p8 = min(max(p8, 0), h8)
                pred = (p8 + 4) >> 3
                frac = p8 - 8 * pred
                sctx = (np.int64(esum > 0) + 2 * np.int64(esum < 0)) * pf.NFRAC + ((frac + 4) >> 1)
                val = v[np.uint64(i)]
                ksign = np.int64(-1)
                if sgn == 1:
                    ksign = pf.N_MODELS_LOW + (ctx * 12 + sctx) * 4 + np.int64(8 * W > p8) + 2 * np.int64(8 * N > p8)
                elif sgn == 2:
                    ksign = pf.N_MODELS_LOW + (ctx * 12 + sctx) * 4 + np.int64(8 * U > p8) + 2 * np.int64(8 * N > p8)
                _cost_residual(models, ctx, sctx, pf._low_class(pred, nlow), val - pred, cost, ksign)
                if extra > 0:
                    perr[np.uint64(r * 8 + 6)] = min(abs(8 * val - q6), 0x3FFFFFFF) if inner else 0
                held = pf._learn(err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
                i += 1


def neighbourhood(offsets) -> tuple[np.ndarray, np.ndarray]:
    o = np.array(offsets, dtype=np.int64)
    margin = np.array([max(o[:, 0].max(), 2), max(o[:, 1].max(), 2), max(o[:, 2].max(), 2),
                       max(-o[:, 2].min(), 1)], dtype=np.int64)  # fmt: skip
    return o, margin


def fit_any(v: np.ndarray, mask, offsets, ncls: int, gmode: int = 0):
    """Weights (2^-12) and thresholds as predictfit.fit does, for any neighbourhood."""
    o, m = neighbourhood(offsets)
    nz, ny, nx = v.shape
    sl = (slice(m[0], nz), slice(m[1], ny - 1), slice(m[2], nx - m[3]))
    tgt = v[sl]
    cols = [v[m[0] - dz : nz - dz, m[1] - dy : ny - 1 - dy, m[2] - dx : nx - m[3] - dx] for dz, dy, dx in o]
    keep = np.ones(tgt.shape, bool) if mask is None else ~mask[sl]
    varies = np.zeros(tgt.shape, bool)
    for c in cols[:16]:
        varies |= c != tgt
    keep &= varies
    x = np.stack([c[keep] for c in cols], axis=1).astype(np.float64)
    y = tgt[keep].astype(np.float64)

    def nb(dz, dy, dx):
        return v[m[0] - dz : nz - dz, m[1] - dy : ny - 1 - dy, m[2] - dx : nx - m[3] - dx][keep].astype(np.float64)

    W, N, U, NW, NE, UW, UN = nb(0, 0, 1), nb(0, 1, 0), nb(1, 0, 0), nb(0, 1, 1), nb(0, 1, -1), nb(1, 0, 1), nb(1, 1, 0)
    g = np.abs(W - NW) + np.abs(N - NW) + np.abs(N - NE)
    if gmode == 0:
        g = g + np.abs(U - UN) + np.abs(U - UW)
    nf = len(o)
    cf = np.zeros(ncls * nf, np.int64)
    th = np.minimum(np.quantile(g, np.arange(1, ncls) / ncls), pf.NO_CLASS).astype(np.int64)
    cls = (g[:, None] > th[None, :]).sum(axis=1) if ncls > 1 else np.zeros(len(g), int)

    def lsq(a, b):
        w, *_ = np.linalg.lstsq(a.T @ a, a.T @ b, rcond=None)
        return np.clip(np.round(w * (1 << pf.CF_BITS)), -pf.CF_LIMIT, pf.CF_LIMIT).astype(np.int64)

    every = lsq(x, y)
    for k in range(ncls):
        s = cls == k
        cf[k * nf : (k + 1) * nf] = lsq(x[s], y[s]) if s.sum() >= 4 * nf else every
    return cf, th


def cost(v, hi, mask, offsets, cf, th, low=True, gmode=0, tex=0, coarse=0, sgn=0, extra=0) -> np.ndarray:
    """Bits of each part of a predict2 stream of ``v`` (values from 0) with these weights."""
    o, margin = neighbourhood(offsets)
    nz, ny, nx = v.shape
    lin = (o[:, 0] * ny * nx + o[:, 1] * nx + o[:, 2]).astype(np.int64)
    flat = np.ascontiguousarray(v, np.int64).reshape(-1)
    mk = np.zeros(flat.size, np.uint8) if mask is None else np.ascontiguousarray(mask, np.uint8).reshape(-1)
    out = np.zeros(5, np.float64)
    err, perr, _, _, _, models, *_ = pf._workspace(v.shape)
    models = np.concatenate([models, np.full(pr.NCTX * 12 * 4, pf.MODEL_INIT, models.dtype)])
    nb = pr.NCTX * 64
    ws = (err, perr, np.zeros(nb, np.int64), np.zeros(nb, np.int64), np.zeros(nb, np.int64), models)
    _cost_kernel(flat, mk, cf, th, lin, margin, np.int64(gmode), np.int64(tex), np.int64(coarse), np.int64(sgn), np.int64(extra), np.array(v.shape, np.int64), np.int64(hi),
                 np.int64(pf.NLOW if low else 0), out, *ws)  # fmt: skip
    return out


def chosen(values: np.ndarray):
    """What the encoder kept for the brick: (payload, domain values from 0, their top,
    mask or None, fitted, low) when it is a predict2 payload, else (payload, None...)."""
    codec = lossless.LosslessCodec()
    payload = codec.encode(values)
    v = values.astype(np.int64)
    if payload[0] != lossless.MODE_PREDICT or not payload[1] & lossless.FLAG_FIT:
        # (analyse the predict2 payload the encoder tried: the shortest one)
        fitp = lossless._encode_fit(v, int(v.min()), int(v.max()), True)
        print(f"  kept {lossless.describe(payload)} {len(payload)} B; predict2 {len(fitp)} B")
        payload = fitp
    flags = payload[1]
    if flags & lossless.FLAG_PALETTE:
        p = pal.build(v)
        v, hi, side = pal.to_ranks(v, p), len(p) - 1, len(pal.pack(p))
    else:
        lo, top = int(v.min()), int(v.max())
        v, hi, side = v - lo, top - lo, len(pal.pack_range(lo, top))
    mask, msec = None, 0
    if flags & lossless.FLAG_MASK:
        fill, mask = bgmask.choose(v)
        msec = len(bgmask.encode(fill, mask))
    return payload, dict(v=v, hi=hi, side=side, mask=mask, mask_bytes=msec, low=bool(flags & lossless.FLAG_LOW))


def bound(a: np.ndarray) -> dict[str, float]:
    """Empirical entropy (bits) of the rounded residual of one least-squares predictor
    over the whole volume, from the neighbours in the 5x5x5 cube: causal (the half
    before the voxel), or from both sides (not causal: a bound no codec reaches), and the
    same within the slice; over the voxels above the 30th percentile (tissue), all for
    volumes without a background."""
    import itertools

    a = a.astype(np.float64)
    nz, ny, nx = a.shape
    y = a[2:-2, 2:-2, 2:-2].ravel()
    keep = y > np.percentile(y, 30) if (a == a.min()).mean() > 0.001 else np.ones(y.shape, bool)
    every = [o for o in itertools.product(range(-2, 3), repeat=3) if o != (0, 0, 0)]
    causal = [o for o in every if o > (0, 0, 0)]
    out = {}
    for label, offs in (("causal", causal), ("both sides", every),
                        ("in-slice causal", [o for o in causal if o[0] == 0]),
                        ("in-slice both sides", [o for o in every if o[0] == 0])):  # fmt: skip
        cols = [a[2 - dz : nz - 2 - dz, 2 - dy : ny - 2 - dy, 2 - dx : nx - 2 - dx].ravel() for dz, dy, dx in offs]
        x = np.stack(cols + [np.ones_like(y)], 1)[keep]
        w = np.linalg.lstsq(x, y[keep], rcond=None)[0]
        _, c = np.unique(np.round(y[keep] - x @ w).astype(np.int64), return_counts=True)
        p = c / c.sum()
        out[label] = float(-(p * np.log2(p)).sum())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--experiments", action="store_true", help="also cost candidate neighbourhoods")
    ap.add_argument("--bound", action="store_true", help="also the least-squares entropy bound")
    args = ap.parse_args()
    for name in args.datasets:
        a, _, _ = datasets.load(name)
        if args.bound:
            print(f"{name}: LS residual entropy, bits: " + ", ".join(f"{k} {v:.3f}" for k, v in bound(a).items()))
        n = a.size
        whole = len(api.compress_array(a))
        payload, info = chosen(a)
        print(f"\n{name} {a.shape} {a.dtype}: file {whole} B ({8 * whole / n:.4f} bits/voxel, ratio "
              f"{a.nbytes / whole:.4f}); payload {len(payload)} B, container {whole - len(payload)} B; "
              f"tool {lossless.describe(payload)}")  # fmt: skip
        if info is None:
            continue
        v, hi, mask = info["v"], info["hi"], info["mask"]
        coded = n - (0 if mask is None else int(mask.sum()))
        fits = pf.fit(v, mask)
        base = None
        for label, ft in (("4 classes", fits[0]), ("1 class", fits[1])):
            c = cost(v, hi, mask, pf.FIT_OFFSETS, ft[0], ft[1], info["low"])
            tot = c.sum() / 8 + pf.HEAD + 2 + info["side"] + info["mask_bytes"]
            base = base or c.sum()
            print(f"  {label}: est. payload {tot:.0f} B; side: range/palette {info['side']} B, mask "
                  f"{info['mask_bytes']} B, fit {pf.HEAD} B; residual bits/coded voxel ({coded}): "
                  + ", ".join(f"{p} {x / coded:.4f}" for p, x in zip(PARTS, c)) + f", all {c.sum() / coded:.4f}")  # fmt: skip
        if not args.experiments:
            continue
        for label, offs, ncls, gmode, tex, coarse, sgn, extra in EXPERIMENTS:
            cf, th = fit_any(v, mask, offs, ncls, gmode)
            c = cost(v, hi, mask, offs, cf, th, info["low"], gmode, tex, coarse, sgn, extra)
            side = 4 * (ncls - 1) + 2 * ncls * len(offs) - pf.HEAD
            print(f"  {label:40s} {c.sum() / coded:.4f} bits/voxel  {100 * ((c.sum() / 8 + side) / (base / 8) - 1):+.2f} % "
                  f"(side {side:+d} B)")  # fmt: skip


BASE = list(pf.FIT_OFFSETS)
# more of the slice: NN-W, NN-E, N-WW, N-EE, NNW W, ... (two rows up, two columns back)
IN2D = [(0, 2, 1), (0, 2, -1), (0, 1, 2), (0, 1, -2), (0, 2, 2), (0, 2, -2), (0, 0, 3), (0, 3, 0)]
Z2 = [(2, 0, 1), (2, 1, 0), (2, 0, -1), (2, -1, 0)]
EXPERIMENTS = [
    # label, neighbourhood, classes, gradient, texture bias, coarse, sign texture, 7th predictor
    ("TEX + gradient in the activity", BASE, 4, 0, 4, -1, 0, 0),
    ("TEX + grad + WW, NN errors in the activity", BASE, 4, 0, 4, -1, 3, 0),
    ("TEX + grad, bias groups c/6", BASE, 4, 0, 4, -1, 4, 0),
]

if __name__ == "__main__":
    main()
