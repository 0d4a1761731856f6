import sys, os, pickle, numpy as np, numba
from volpack.volume_codec import predictfit
from volpack.volume_codec.predictfit import FIT_OFFSETS
OFF = np.array(FIT_OFFSETS, np.int64)
@numba.njit
def nlms(v, w0, mu, center):
    nz, ny, nx = v.shape; nf = OFF.shape[0]
    w = w0.copy(); f = np.empty(nf); out = np.full(v.size, -1, np.int64)
    for z in range(2, nz):
        for y in range(2, ny - 1):
            for x in range(2, nx - 1):
                m = 0.0
                for k in range(nf):
                    f[k] = v[z - OFF[k, 0], y - OFF[k, 1], x - OFF[k, 2]]
                    m += f[k]
                m = m / nf if center else 0.0
                p = m; ss = 1.0
                for k in range(nf):
                    f[k] -= m; p += w[k] * f[k]; ss += f[k] * f[k]
                out[(z * ny + y) * nx + x] = int(np.round(8 * p))
                e = v[z, y, x] - p
                g = mu * e / ss
                for k in range(nf):
                    w[k] += g * f[k]
    return out
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    enc = lambda: len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    b8 = enc(); out = []
    v = (c['values'] - c['lo']).astype(np.float64)
    cf = predictfit.fit(c['values'] - c['lo'])[1][0][:16] / 4096.0
    for center in (0, 1):
        w0 = cf.copy()
        if center: w0 = w0 - w0.mean() * 0  # weights on centered features; mean term is implicit 1
        for mu in (0.002, 0.01, 0.05):
            predictfit.LP = nlms(v, w0, mu, center); b = enc(); predictfit.LP = None
            out.append(f"c{center} mu {mu}: {100*(b8/b-1):+.2f}")
    print(f"{n:16s} v8 {b8}:", ' | '.join(out), flush=True)
