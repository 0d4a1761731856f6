"""Where volpack's bits go on a noise-limited volume: the predictive coder (predict
version 8's payload predict2+low+tex+mix, as the encoder picks on these volumes) run
with NUMBA_DISABLE_JIT=1 on a crop, every decision's cost recorded, against
(a) the order-0 entropy of the values (the bound on iid noise), (b) the order-0 entropy
of the residuals of its blend, of its fitted predictor alone and of volpack's final
prediction, (c) the static conditional entropy of each decision given its model.

    NUMBA_DISABLE_JIT=1 PYTHONPATH=. python results/lossless/noise39/trace.py F.npy [z0:z1,y0:y1,x0:x1]
"""

from __future__ import annotations

import sys
from collections import defaultdict

import numpy as np

from volpack.volume_codec import predictfit as pf
from volpack.volume_codec import residmix


def h0(a):
    _, c = np.unique(a, return_counts=True)
    p = c / c.sum()
    return float(-(p * np.log2(p)).sum())


def hcond(x, ctx):
    """Static conditional entropy H(x | ctx) in bits per item, summed over items."""
    key = np.stack([ctx, x], 1)
    _, inv, cnt = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    _, cinv, ccnt = np.unique(ctx, return_inverse=True, return_counts=True)
    return float(-np.log2(cnt[inv.ravel()] / ccnt[cinv.ravel()]).sum())


rec_pred = []
dec = []  # (kind, model k, bit, cost)
raw = [0]
rawv = []
orig_predict = pf._predict_mix
orig_put = pf._put16m
orig_bits = pf.put_bits


def predict_mix(*a):
    o = orig_predict(*a)
    rec_pred.append((o[0], o[1], o[7], o[11]))  # pred, ctx, q2 (fitted, eighths), blend (eighths)
    return o


def put16m(out, models, k, bit, low, rng, pos, aux, mx, slot, kind):
    st = int(models[np.uint64(k)])
    p = st >> 8
    if residmix.mixing(mx, p):
        p, _ = residmix.mix(p, aux, mx, slot, kind)
    p = int(p) / 65536
    dec.append((int(kind), int(k), int(bit), -np.log2(p if bit == 0 else 1 - p), len(rec_pred) - 1))
    return orig_put(out, models, k, bit, low, rng, pos, aux, mx, slot, kind)


def put_bits(out, u, n, low, rng, pos):
    raw[0] += max(int(n), 0)
    rawv.append((len(rec_pred) - 1, max(int(n), 0)))
    return orig_bits(out, u, n, low, rng, pos)


pf._predict_mix = predict_mix
pf._put16m = put16m
pf.put_bits = put_bits

a = np.load(sys.argv[1])
if len(sys.argv) > 2:
    a = a[tuple(slice(*map(int, s.split(":"))) for s in sys.argv[2].split(","))]
v = a.astype(np.int64)
lo, hi = int(v.min()), int(v.max())
body = pf.encode(v, lo, hi, low=True, tex=True, mix=True)
n = v.size
assert len(rec_pred) == n, (len(rec_pred), n)
P = np.array(rec_pred, dtype=np.int64)
val = (v - lo).ravel()
pred, ctx, q2, pb = P.T
kinds = np.array([d[0] for d in dec])
ks = np.array([d[1] for d in dec])
bits = np.array([d[2] for d in dec])
cost = np.array([d[3] for d in dec])
name = {0: "zero flag", 1: "sign"}
groups = defaultdict(list)
for j, kd in enumerate(kinds):
    groups[
        "zero flag" if kd == 0 else "sign" if kd == 1 else "length" if kd < 14 else "mantissa"
    ].append(j)
print(f"{sys.argv[1]} crop {a.shape}, range [{lo}, {hi}], {n} voxels")
print(
    f"stream {8 * len(body) / n:.4f} bits/voxel; coded decisions {cost.sum() / n:.4f} + raw bits {raw[0] / n:.4f}"
)
print(f"H0 of the values {h0(val):.4f}")
r_final = val - pred
r_fit = val - ((q2 + 4) >> 3)
r_blend = val - ((pb + 4) >> 3)
print(
    f"H0 of residuals: final {h0(r_final):.4f}, blend {h0(r_blend):.4f}, fitted alone {h0(r_fit):.4f}"
)
print(
    f"H(value | final prediction) {hcond(val, pred) / n:.4f}; H(value | fitted) {hcond(val, (q2 + 4) >> 3) / n:.4f}"
)
print("| decision | count/voxel | adaptive bits/voxel | static H given its model | excess |")
print("|---|---|---|---|---|")
for g, idx in groups.items():
    idx = np.array(idx)
    hs = hcond(bits[idx], ks[idx]) / n
    print(
        f"| {g} | {idx.size / n:.3f} | {cost[idx].sum() / n:.4f} | {hs:.4f} | {cost[idx].sum() / n - hs:+.4f} |"
    )
print(f"| raw bits | {raw[0] / n:.3f} | {raw[0] / n:.4f} | | |")


# The low-value class (prediction below NLOW): its zero flag, sign and lengths have
# models keyed on the prediction, its mantissa bits do not (keyed on the activity) and
# bits past the second below the leading one go at one half. Simulated: the mantissa
# bits (up to 3) in adaptive models keyed on (prediction, sign, length, prefix), the
# same adaptation rule (residmix.adapted), the rest as coded.
vox = np.array([d[4] for d in dec])
low = pred < pf.NLOW
lowd = low[vox]
cur_mr = cost[lowd & (kinds >= 14)].sum() + sum(b for i, b in rawv if low[i])
models = {}
sim = 0.0
for i in np.flatnonzero(low & (r_final != 0)):
    r = int(r_final[i])
    u = abs(r) - 1
    nb = u.bit_length()
    nm = min(nb - 1, 3)
    prefix = 1
    for jm in range(max(nm, 0)):
        bit = (u >> (nb - 2 - jm)) & 1
        key = (int(pred[i]), r < 0, nb, prefix)
        st = models.get(key, int(residmix.MODEL_INIT))
        pp = (st >> 8) / 65536
        sim += -np.log2(pp if bit == 0 else 1 - pp)
        models[key] = int(residmix.adapted(st >> 8, st & 255, -bit))
        prefix = 2 * prefix + bit
    sim += max(nb - 1 - max(nm, 0), 0)
nl = low.sum()
print(
    f"low class: {nl / n:.3f} of the voxels; their mantissa + raw bits {cur_mr / n:.4f} bits/voxel now, "
    f"{sim / n:.4f} with models keyed on the prediction ({(sim - cur_mr) / n:+.4f})"
)
cur_all = cost[lowd].sum() + sum(b for i, b in rawv if low[i])
print(
    f"low class coded at {cur_all / max(nl, 1):.4f} bits each; H(value | prediction) there "
    f"{hcond(val[low], pred[low]) / max(nl, 1):.4f}"
)
