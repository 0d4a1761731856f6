import sys, os, pickle, numpy as np
from volpack.volume_codec import predictfit
from volpack.volume_codec.predictfit import FIT_OFFSETS
def class_lp(v, scheme, K):
    nz, ny, nx = v.shape
    zs, ys, xs = np.meshgrid(np.arange(2, nz), np.arange(2, ny - 1), np.arange(2, nx - 1), indexing='ij')
    zs, ys, xs = zs.ravel(), ys.ravel(), xs.ravel()
    X = np.stack([v[zs - a, ys - b, xs - c] for a, b, c in FIT_OFFSETS], 1).astype(np.float64)
    y = v[zs, ys, xs].astype(np.float64)
    W, N, U, NW, NE, UW, UN = (X[:, k] for k in range(7))
    g = np.abs(W - NW) + np.abs(N - NW) + np.abs(N - NE) + np.abs(U - UN) + np.abs(U - UW)
    if scheme == 'grad':
        th = np.quantile(g, np.arange(1, K) / K); cls = (g[:, None] > th[None]).sum(1)
    else:  # grad quartile x level (mean of W,N,U) split in K//4
        th = np.quantile(g, np.arange(1, 4) / 4); cg = (g[:, None] > th[None]).sum(1)
        lv = (W + N + U) / 3; tl = np.quantile(lv, np.arange(1, K // 4) / (K // 4)); cl = (lv[:, None] > tl[None]).sum(1)
        cls = cg * (K // 4) + cl
    lp = np.full(v.size, -1, np.int64)
    pred = np.zeros(len(y))
    for k in range(K):
        m = cls == k
        if m.sum() < 64: continue
        w, *_ = np.linalg.lstsq(X[m], y[m], rcond=None)
        w = np.round(w * 4096) / 4096
        pred[m] = X[m] @ w
    lp[(zs * ny + ys) * nx + xs] = np.round(8 * pred).astype(np.int64)
    return lp
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    enc = lambda: len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    b8 = enc(); out = []
    v = c['values'] - c['lo']
    for scheme, K in (('grad', 4), ('grad', 8), ('grad', 16), ('gl', 8), ('gl', 16)):
        predictfit.LP = class_lp(v, scheme, K); b = enc() + (K - 4) * 32; predictfit.LP = None
        out.append(f"{scheme}{K}: {100*(b8/b-1):+.2f}")
    print(f"{n:16s} v8 {b8}:", ' | '.join(out), flush=True)
