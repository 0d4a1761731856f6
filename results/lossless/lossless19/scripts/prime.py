import sys, pickle, numpy as np
from volpack.volume_codec import predictfit
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    v = c['values']
    for mix in (True,):
        b1 = len(predictfit.encode(v, c['lo'], c['hi'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=mix))
        vv = np.concatenate([v, v], 0)
        b2 = len(predictfit.encode(vv, c['lo'], c['hi'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=mix))
        # second copy different content: flip to avoid cross-slice copying advantage
        vf = np.concatenate([v[:, ::-1, ::-1], v], 0)
        b3 = len(predictfit.encode(vf, c['lo'], c['hi'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=mix))
        print(n, 'mix', mix, 'once', b1, 'second copy costs', b2 - b1, f'({100*(b1/(b2-b1)-1):+.2f} %)', 'after a flipped copy', b3 - len(predictfit.encode(v[:, ::-1, ::-1], c['lo'], c['hi'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=mix)))
