"""Scratch (session 23): the real `effort="max"` (predict_version 9) file with the
residual coder changed per hypothesis, by a copy of predictfit's encoder kernel put in
its place (mode 0 reproduces version 9's bytes: checked). The coder is the real one
(adaptive 16-bit models, the mix), so a length is what a version 11 encoder would
write; bytes a decoder would need (thresholds) are added per call and the keep-where-
shorter choices of lossless._encode_fit run as they do for version 9.

Modes (per brick, all causal: they read only the prediction and the activity):
  int:K:KIND   model 1 (the activity-context models) split by K buckets of the
               prediction; KIND q = quantiles of the brick's values (stored, 4 B each),
               log = fixed octaves below the range's top
  act:K        activity classes from K-1 thresholds at quantiles of the brick's activity
               (a first pass with version 9 records it; stored, 2 B each), coding only
  actm:M       the existing 48 log classes merged upward until each holds >= M voxels
               (first pass; stored as a 48-bit map, 6 B)
  actint:KA:KI activity classes from KA-1 thresholds at quantiles of the activity within
               each of KI buckets of the value (noise scaled by intensity; stored)
  spreadint:3:KIND  the three classes of the predictors' spread replaced by three
               buckets of the prediction (as many contexts as version 9)
  warm:N       a bound, not a coder: the coding models (and the mix) start as a first pass
               over the same brick left them, their use counts capped at N
  wpow:P       (prediction side) the blend's weights ~ 1 / (1 + s)^P instead of P = 2
               (the choice stored: 1 B)
  pswap:S      (prediction side) one of the blend's six predictors replaced: 1 (W+NE)/2
               by W+NE-N, 2 by (W+N+NE+NW)/4; U by 3 W+NE-N, 4 (W+N+NE+NW)/4, 5 (W+N)/2
  spreadlf     the spread class of model 1's context counts the local fit's estimate too
  spreadbl     the spread class from 2 |blend - local fit| alone (where there is a local fit)
  bias:K:KIND  the bias correction kept per (bias slot, bucket of the blend)
    PYTHONPATH=. python results/lossless/noisy23/scripts/hyp.py NAMES MODE...
"""
import json, sys, time
import numpy as np
sys.path.insert(0, "scripts")
import datasets
from volpack import api
from volpack._jit import kernel
from volpack.volume_codec import predictfit as pf, localfit, residmix
from volpack.volume_codec.predict import weight, floor_div_recip, context, NCTX, NACT, NSPREAD, activity_class
from volpack.entropy.rangecoder import open_encoder, finish_stream

ORIG = pf._encode_kernel
NBIAS = pf.NBIAS
CFG_K = 2  # (spreadbl's scale of |blend - local fit|)
CFGW = [2]  # the blend's weight exponent (version 9: 2), passed to the kernel


@kernel(inline=True)
def bucket(p, th):
    b = 0
    for k in range(th.size):
        b += p > th[k]
    return b


@kernel(inline=True)
def wt(s, p):
    if p == 2:
        return pf._weight2(s)
    w = weight(s + 1)
    if p == 1:
        return w
    return max((pf._weight2(s) * w) >> 24, 1)  # p == 3


@kernel(inline=True)
def predict(v, cf, th, err, perr, i, r, ru, z, y, x, ny, nx, hi, bias, held, tex, lpe, lw, bmode, thb, wp, ps):
    # a copy of predictfit._predict_kernel, the bias slot optionally split by bucket
    W, N, U, NW, NE, UW, UN, UNW, act2, esum, s0, s1, s2, s3, s4, s5 = pf._gather(
        v, err, perr, i, r, ru, z, y, x, ny, nx, hi, held)
    h8 = 8 * hi
    q0 = min(max(8 * (W + N - NW), 0), h8)
    q1 = min(max(8 * (U + W - UW), 0), h8)
    if z >= 2 and y >= 2 and x >= 2 and x + 1 < nx and y + 1 < ny:
        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
        c = (np.int64(g > th[0]) + np.int64(g > th[1]) + np.int64(g > th[2])) * pf.NFIT
        q2 = min(max(pf._fitted(v, cf, c, i, nx, ny * nx), 0), h8)
    else:
        q2 = min(max(8 * (U + N - UN), 0), h8)
    q3 = min(max(8 * (W + N + U - NW - UW - UN + UNW), 0), h8)
    q4 = 8 * U
    q5 = 4 * (W + NE)
    if ps == 1:
        q5 = min(max(8 * (W + NE - N), 0), h8)
    elif ps == 2:
        q5 = 2 * (W + N + NE + NW)
    elif ps == 3:
        q4 = min(max(8 * (W + NE - N), 0), h8)
    elif ps == 4:
        q4 = 2 * (W + N + NE + NW)
    elif ps == 5:
        q4 = 4 * (W + N)
    if tex:
        g = abs(W - NW) + abs(N - NW) + abs(N - NE) + abs(U - UN) + abs(U - UW)
        act = (act2 + g) >> 1
    else:
        act = act2 >> 1
    w0 = wt(s0, wp); w1 = wt(s1, wp); w2 = wt(s2, wp)
    w3 = wt(s3, wp); w4 = wt(s4, wp); w5 = wt(s5, wp)
    den = w0 + w1 + w2 + w3 + w4 + w5
    rden = 1.0 / np.float64(den)
    num = w0 * q0 + w1 * q1 + w2 * q2 + w3 * q3 + w4 * q4 + w5 * q5
    ctx = context(act, (max(q0, q1, q2, q3, q4, q5) - min(q0, q1, q2, q3, q4, q5)) >> 3)
    p0 = floor_div_recip(num + (den >> 1), den, rden)
    pb = p0
    lq = localfit.NONE
    if lpe != localfit.NONE:
        lq = min(max(lpe, 0), h8)
        eb = lw[np.uint64(2 * ctx)]
        el = lw[np.uint64(2 * ctx + 1)]
        eb *= eb
        el *= el
        k = (16 * eb + ((eb + el) >> 1)) // (eb + el) if eb + el > 0 else 8
        p0 = (p0 * (16 - k) + lq * k + 8) >> 4
    bctx = pf._texture_bias(ctx, p0, W, N, U, NE, NW, UN) if tex else ctx
    if bmode:
        bctx += NBIAS * bucket(p0 >> 3, thb)
    p8 = min(max(p0 + bias[np.uint64(bctx)], 0), h8)
    pred = (p8 + 4) >> 3
    frac = p8 - 8 * pred
    sctx = (np.int64(esum > 0) + 2 * np.int64(esum < 0)) * pf.NFRAC + ((frac + 4) >> 1)
    return pred, ctx, bctx, sctx, act, q0, q1, q2, q3, q4, q5, pb, lq


@kernel(nrt=False)
def enc(v, mk, cf, th, shape, hi, nlow, tex, mix, lp, ls, out, err, perr, bias_sum, bias_cnt, bias,
        models, aux, lw, mode, thi, tha, lut, rec, wp):
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    cap = out.size
    low, rng, pos = open_encoder(out)
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                if pos + 64 > cap:
                    return -1
                r = cur + y * nx + x
                if mk[np.uint64(i)]:
                    held = pf._skip(err, perr, r, v[np.uint64(i)])
                    i += 1
                    continue
                lpe = lp[np.uint64(i)] if ls else localfit.NONE
                pred, ctx, bctx, sctx, act, q0, q1, q2, q3, q4, q5, pb, lq = predict(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held, tex,
                    lpe, lw, mode == 4, thi, wp % 16, wp // 16)
                mx = residmix.NO_MIX
                if mix:
                    mx = residmix.contexts(err, r, r - cur + prev, y, x, ny, nx, act, ctx, pred)
                val = v[np.uint64(i)]
                rec[np.uint64(3 * i)] = act
                rec[np.uint64(3 * i + 1)] = pred
                rec[np.uint64(3 * i + 2)] = val - pred
                q = pf._low_class(pred, nlow)
                b = 0
                cc = ctx
                if mode == 1:
                    b = bucket(pred, thi)
                elif mode == 2:
                    cc = min(bucket(act, tha[0]), NACT - 1) * NSPREAD + ctx % NSPREAD
                elif mode == 6:
                    cc = (ctx // NSPREAD) * NSPREAD + min(bucket(pred, thi), NSPREAD - 1)
                elif mode == 11 and lq != localfit.NONE:  # the local fit's disagreement in the spread
                    sp = max(q0, q1, q2, q3, q4, q5, lq) - min(q0, q1, q2, q3, q4, q5, lq)
                    cc = context(act, sp >> 3)
                elif mode == 12 and lq != localfit.NONE:  # spread classes from |blend - local fit|
                    cc = context(act, (CFG_K * abs(pb - lq)) >> 3)
                elif mode == 5:
                    cc = min(bucket(act, tha[bucket(pred, thi)]), NACT - 1) * NSPREAD + ctx % NSPREAD
                elif mode == 3:
                    cc = lut[np.uint64(ctx // NSPREAD)] * NSPREAD + ctx % NSPREAD
                low, rng, pos = pf.put_residual_mix(
                    out, models[b], cc, sctx, q, val - pred, low, rng, pos, aux, mx)
                held = pf._learn(err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2,
                                 q3, q4, q5)
                pf._learn_local(lw, ctx, val, pb, lq)
                i += 1
    return finish_stream(out, low, pos)


CFG = {"mode": 0, "k": 1, "kind": "q", "m": 0}
EXTRA = [0]
LAST = []


def run_kernel(args, mode, thi, tha, lut, rec):
    (flat, mk, cf, th, shape, hi, nlow, tex, mix, lp, ls, out, err, perr, bias_sum, bias_cnt, bias,
     models, aux, lw) = args
    K = max(thi.size + 1, 1) if mode not in (5, 6) else 1
    models2 = np.repeat(models[None, :], K, axis=0)
    if mode == 4:
        bias_sum = np.zeros(NBIAS * K, np.int64); bias_cnt = bias_sum.copy(); bias = bias_sum.copy()
    return enc(flat, mk, cf, th, shape, hi, nlow, tex, mix, lp, ls, out, err, perr, bias_sum, bias_cnt,
               bias, models2, aux, lw, mode, thi, tha, lut, rec, CFGW[0])


def patched(*args):
    flat, mk, hi = args[0], args[1], int(args[5])
    out = args[11]
    fresh = lambda: [a.copy() if isinstance(a, np.ndarray) and j >= 12 else a for j, a in enumerate(args)]
    mode, k, kind = CFG["mode"], CFG["k"], CFG["kind"]
    extra0 = EXTRA[0]
    EXTRA[0] = 0
    e = np.zeros(0, np.int64)
    thi = e
    tha = np.zeros((1, 0), np.int64)
    lut = np.arange(NACT, dtype=np.int64)
    rec = np.zeros(3 * flat.size, np.int64)
    coded = mk == 0
    if mode in (1, 4, 6):
        if kind == "q":
            thi = np.unique(np.quantile(flat[coded], np.arange(1, k) / k).astype(np.int64))
            EXTRA[0] += 1 + 4 * thi.size
        else:  # fixed octaves below the top of the range
            thi = np.array(sorted({max((hi + 1) >> (j + 1), 0) for j in range(k - 1)}), np.int64)
    if mode in (2, 3, 5):
        a = fresh(); a[11] = out.copy()
        run_kernel(a, 0, e, tha, lut, rec)
        acts = rec[0::3][coded]
        if mode == 2:
            tha = np.quantile(acts, np.arange(1, k) / k).astype(np.int64)[None, :]
            EXTRA[0] += 1 + 2 * tha.size
        elif mode == 5:  # activity quantiles within each bucket of the prediction
            ki = CFG["m"]
            thi = np.quantile(flat[coded], np.arange(1, ki) / ki).astype(np.int64)
            pr = flat[coded]  # (the value's bucket stands for the prediction's here)
            bk = np.searchsorted(thi, pr, side="left")
            tha = np.stack([np.quantile(acts[bk == j] if (bk == j).sum() else acts, np.arange(1, k) / k)
                            for j in range(ki)]).astype(np.int64)
            EXTRA[0] += 1 + 4 * thi.size + 2 * tha.size
        else:
            h = np.bincount(np.array([_ac(int(t)) for t in acts]), minlength=NACT)
            cur, n = 0, 0
            for c in range(NACT):  # merge upward until a class holds >= m voxels
                lut[c] = cur
                n += h[c]
                if n >= CFG["m"]:
                    cur += 1; n = 0
            if n and cur > 0 and n < CFG["m"]:  # fold a small last class into the one before
                lut[lut == cur] = cur - 1
            EXTRA[0] += 6
    if mode in (11, 12):
        return run_kernel(args, mode, thi, tha, lut, rec)
    if mode == 10:  # diagnostic: version 9's own run, its activity, prediction and residual kept
        st = run_kernel(args, 0, thi, tha, lut, rec)
        LAST[:] = [rec.reshape(-1, 3)[coded].copy()]
        return st
    if mode in (8, 9):
        CFGW[0] = CFG["m"] if mode == 8 else 2 + 16 * CFG["m"]
        EXTRA[0] = max(EXTRA[0], extra0, 1)
        try:
            return run_kernel(args, 0, thi, tha, lut, rec)
        finally:
            CFGW[0] = 2
    if mode == 7:  # the bound of a perfect start: the coding models as a first pass left them
        a = fresh(); a[11] = out.copy()
        K = 1
        models2 = a[17][None, :].copy()
        enc(*a[:17], models2, a[18], *a[19:], 0, e, tha, lut, rec, CFGW[0])
        m, x = models2[0], a[18]
        n = CFG["m"]
        m = (m & ~np.uint32(255)) | np.minimum(m & np.uint32(255), n).astype(np.uint32)
        x = x.copy()
        x[:residmix.W_BASE] = (x[:residmix.W_BASE] & ~np.uint32(255)) | np.minimum(
            x[:residmix.W_BASE] & np.uint32(255), n).astype(np.uint32)
        args = list(args)
        args[17], args[18] = m, x
        mode = 0
    EXTRA[0] = max(EXTRA[0], extra0)  # one brick's stored bytes (the largest of the calls)
    return run_kernel(args, mode, thi, tha, lut, rec)


def _ac(a):
    if a < 4:
        return a
    b = a.bit_length() if a >= 4 else 3
    b = (a | 4).bit_length()
    return min(2 * b - 2 + ((a >> (b - 2)) & 1), NACT - 1)


def size(arr, spec):
    parts = spec.split(":")
    CFG.update(mode={"base": 0, "int": 1, "act": 2, "actm": 3, "bias": 4, "actint": 5, "spreadint": 6, "warm": 7, "wpow": 8, "pswap": 9, "diag": 10, "spreadlf": 11, "spreadbl": 12}[parts[0]])
    if parts[0] in ("int", "bias", "spreadint"):
        CFG.update(k=int(parts[1]), kind=parts[2])
    elif parts[0] == "act":
        CFG.update(k=int(parts[1]))
    elif parts[0] == "actint":
        CFG.update(k=int(parts[1]), m=int(parts[2]))
    elif parts[0] in ("actm", "warm", "wpow", "pswap"):
        CFG.update(m=int(parts[1]))
    EXTRA[0] = 0
    pf._encode_kernel = patched
    try:
        data = api.compress_array(arr, effort="max", workers=1)
    finally:
        pf._encode_kernel = ORIG
    return data, EXTRA[0]


if __name__ == "__main__":
    names = sys.argv[1].split(",")
    specs = sys.argv[2:]
    for name in names:
        arr, _, _ = datasets.load(name)
        ref = api.compress_array(arr, effort="max", workers=1)
        t = time.time()
        d0, _ = size(arr, "base")
        assert d0 == ref, "mode 0 does not reproduce version 9"
        for spec in specs:
            d, extra = size(arr, spec)
            n = len(d) + extra
            print(json.dumps(dict(name=name, spec=spec, v9=len(ref), bytes=len(d), extra=extra,
                                  total=n, gain_pct=round(100 * (len(ref) - n) / len(ref), 3))), flush=True)
