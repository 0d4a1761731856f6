import sys, os, pickle, numpy as np
from volpack.volume_codec import predictfit
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    r = []
    for nl in (16, 24, 32, 48, 64, 128):
        os.environ['VP_NLOW'] = str(nl)
        r.append((nl, len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=True, tex=c['tex'], mix=True))))
    print(n, 'low was', c['low'], r, flush=True)
