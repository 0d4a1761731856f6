import time, numpy as np
import volpack
from volpack.volume_codec import predictfit
rng = np.random.default_rng(0)
v = rng.integers(0, 200, size=(8, 9, 10)).astype(np.int64)
t = time.process_time(); d = predictfit.encode(v, 0, 255, low=True, tex=True); te = time.process_time() - t
t = time.process_time(); predictfit.decode(d, v.shape, 0, 255, low=True, tex=True); td = time.process_time() - t
print(volpack.__file__, f"encode compile {te:.1f} s, decode compile {td:.1f} s")
