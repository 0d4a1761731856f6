"""cProfile and best-of-20 process time of one lossy decode (``api.decompress_array``)
of a real field at a bound relative to its range, ``effort="fast"``:

    python results/lossy/fixed24/prof.py cam_t 1e-2
"""
import os, sys, time, cProfile, pstats
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "scripts"))
import datasets, numpy as np
from volpack import api
name = sys.argv[1]; rel = float(sys.argv[2])
a, sp, t = datasets.load(name)
rng = float(a.max() - a.min())
blob = api.compress_array(a, max_error=rel * rng, effort="fast") if hasattr(api, 'compress_array') else None
print(name, a.shape, a.dtype, len(blob))
for _ in range(3): api.decompress_array(blob)
ts = []
for _ in range(20):
    t0 = time.process_time(); api.decompress_array(blob); ts.append(time.process_time() - t0)
print('best ms', min(ts) * 1e3, 'MB/s', a.nbytes / min(ts) / 1e6)
pr = cProfile.Profile(); pr.enable()
for _ in range(50): api.decompress_array(blob)
pr.disable()
pstats.Stats(pr).sort_stats("cumtime").print_stats(25)
