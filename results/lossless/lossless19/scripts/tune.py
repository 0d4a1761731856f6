import sys, pickle, time, itertools, numpy as np
from volpack.volume_codec import predictfit, residmix
names = ['mri_nibabel_t1', 'mri_dipy_s0', 'brainsmall', 'mri_epi_nibabel', 'mri_dipy_aniso']
names = [n for n in names if n in sys.argv[1].split(',')] if len(sys.argv) > 1 and sys.argv[1] else names
calls = {n: pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[0] for n in names}
def enc(c, mix):
    return predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=mix)
base = {n: len(enc(c, True)) for n, c in calls.items()}
print('v8', base, flush=True)
confs = eval(sys.argv[2])  # list of dicts knob index -> value
check = len(sys.argv) > 3
for conf in confs:
    k = list(residmix.KNOBS)
    saved = list(residmix.KNOBS)
    for i, v in conf.items(): residmix.KNOBS[i] = v
    t0 = time.time()
    out = []
    for n, c in calls.items():
        b = enc(c, 2)
        if check:
            d = predictfit.decode(b[:], c['values'].shape, c['lo'], c['hi'], c['mask'], 0 if c['mask'] is None else 0, c['low'], c['tex'], 2)
            if c['mask'] is None: assert np.array_equal(d, c['values']), n
            else:
                mk = c['mask'].astype(bool); assert np.array_equal(d[~mk], c['values'][~mk]), n
        out.append(f"{n[:10]} {100*(base[n]/len(b)-1):+.2f}%")
    residmix.KNOBS[:] = saved
    print(conf, ' | '.join(out), f"{time.time()-t0:.0f}s", flush=True)
