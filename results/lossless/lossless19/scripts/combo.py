import sys, os, pickle, numpy as np
sys.path.insert(0, '/tmp/l19')
from volpack.volume_codec import predictfit, residmix
from localls import local_ls
confs = eval(sys.argv[2])
for n in sys.argv[1].split(','):
    c = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0]
    def enc(mix, nlow, lp):
        os.environ['VP_NLOW'] = str(nlow); predictfit.LP = lp
        b = len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'] or nlow != 16, tex=c['tex'], mix=mix))
        predictfit.LP = None; os.environ['VP_NLOW'] = '16'; return b
    b8 = enc(True, 16, None)
    lp = local_ls((c['values'] - c['lo']).astype(np.float64), 4, 3, 1e-3, 40)
    out = []
    for conf, nlow, uselp in confs:
        saved = list(residmix.KNOBS)
        for i, v in (conf or {}).items(): residmix.KNOBS[i] = v
        b = enc(2 if conf is not None else True, nlow, lp if uselp else None)
        residmix.KNOBS[:] = saved
        out.append(f"{100*(b8/b-1):+.2f}")
    print(f"{n:16s} v8 {b8}:", ' '.join(out), flush=True)
