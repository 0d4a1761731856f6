import sys, pickle, numpy as np
sys.path.insert(0, 'scripts')
import datasets
from volpack import api
from volpack.volume_codec import predictfit
orig = predictfit.encode
calls = []
def enc(values, lo, hi, classes=4, mask=None, fitted=None, low=False, tex=False, mix=False):
    if mix:
        calls.append(dict(values=np.asarray(values), lo=lo, hi=hi, mask=None if mask is None else np.asarray(mask), fitted=fitted, low=low, tex=tex))
    return orig(values, lo, hi, classes, mask, fitted, low, tex, mix)
predictfit.encode = enc
for name in sys.argv[1:]:
    calls.clear()
    a = datasets.load(name)[0]
    b = api.compress_array(a, workers=1)
    print(name, a.shape, a.dtype, len(b), a.nbytes/len(b), len(calls), flush=True)
    pickle.dump(list(calls), open(f'/tmp/l19/{name}.pkl', 'wb'))
