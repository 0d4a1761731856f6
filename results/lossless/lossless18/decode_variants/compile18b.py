import time, numpy as np
import volpack
from volpack.volume_codec import bounded_interp as bi
from volpack.volume_codec.predictfit import MODEL_INIT, N_MODELS
abin = np.array([0, 1, -3, 5], np.int64); adx = np.array([0, 4, 9, 2], np.int64)
models = np.full(N_MODELS, MODEL_INIT, np.uint32); out = np.zeros(4096, np.uint8)
t = time.process_time(); bi._encode_adaptive(abin, adx, models, out); te = time.process_time() - t
t = time.process_time(); bi._adaptive_bin(out, models, np.int64(0), np.int64(0), np.int64(0), np.int64(1 << 32 - 1), np.int64(0)); td = time.process_time() - t
print(volpack.__file__, f"_encode_adaptive compile {te:.1f} s, _adaptive_bin {td:.1f} s")
