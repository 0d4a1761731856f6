import sys, pickle, time, numpy as np
sys.path.insert(0, '/tmp/l19')
from volpack.volume_codec import predictfit
from localls import local_ls
names = sys.argv[1].split(',')
for n in names:
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    enc = lambda: len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    predictfit.LP = None; b8 = enc()
    v = (c['values'] - c['lo']).astype(np.float64)
    for R, RU, lam in eval(sys.argv[2]):
        t = time.time(); lp = local_ls(v, R, RU, lam, 40); dt = time.time() - t
        predictfit.LP = lp; b = enc(); predictfit.LP = None
        print(n, R, RU, lam, f"v8 {b8} -> {b} ({100*(b8/b-1):+.2f} %) lp {dt:.1f}s", flush=True)
