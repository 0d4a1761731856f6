import sys, pickle, numpy as np
from scipy import ndimage
from volpack.volume_codec import predictfit
c = pickle.load(open('/tmp/l19/mri_dipy_s0.pkl', 'rb'))[0]
v = c['values']
for T in (48, 80, 120):
    bg = ndimage.maximum_filter(v, size=(1, 5, 5)) < T
    h = np.bincount(v[bg]); p = h[h > 0] / bg.sum()
    H = -(p * np.log2(p)).sum()
    full = len(predictfit.encode(v, c['lo'], c['hi'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    onlybg = len(predictfit.encode(v, c['lo'], c['hi'], mask=~bg, fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    nobg = len(predictfit.encode(v, c['lo'], c['hi'], mask=bg, fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
    print(f"T {T} bg share {bg.mean():.3f} n {bg.sum()} H0 {H:.3f} bits -> {bg.sum()*H/8:.0f} B; codec bg-only {onlybg} B ({onlybg*8/bg.sum():.3f} b/vox), rest-only {nobg}, full {full}, full-rest {full-nobg}")
