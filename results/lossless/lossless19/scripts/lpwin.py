import sys, os, time, pickle, numpy as np
sys.path.insert(0, '/tmp/l19')
from volpack.volume_codec import predictfit
from localls import local_ls
wins = eval(sys.argv[2])
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    enc = lambda: len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    b8 = enc(); out = []
    v = (c['values'] - c['lo']).astype(np.float64)
    local_ls(v[:3, :4, :5].copy(), 1, 1, 1e-3, 40)
    for R, RU, lam in wins:
        t = time.process_time(); lp = local_ls(v, R, RU, lam, 40); dt = time.process_time() - t
        predictfit.LP = lp; b = enc(); predictfit.LP = None
        out.append(f"R{R}/{RU} lam {lam:g}: {100*(b8/b-1):+.2f} % ({1e6*dt/v.size:.1f} us/voxel)")
    print(f"{n:16s} v8 {b8}:", ' | '.join(out), flush=True)
