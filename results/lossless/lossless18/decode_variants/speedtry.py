"""v8 against v7 in one process: bytes and decode CPU time (alternating, best of N)."""
import sys, time, numpy as np
sys.path.insert(0, 'scripts')
import datasets
from volpack import api
rep = 5
names = sys.argv[1:]
tot = {}
for name in names:
    a = datasets.load(name)[0]
    if name == 'ct_head':
        a = a[:64]
    b = {7: api.compress_array(a, predict_version=7), 8: api.compress_array(a)}
    t = {7: [], 8: []}
    for _ in range(rep):
        for k in (7, 8):
            t0 = time.process_time(); back = api.decompress_array(b[k], workers=1); t[k].append(time.process_time() - t0)
            assert np.array_equal(back, a)
    g = 100 * (len(b[7]) / len(b[8]) - 1)
    print(f"{name:16s} ratio {a.nbytes/len(b[8]):.4f} gain {g:+.3f} %  decode x{min(t[8])/min(t[7]):.3f} ({min(t[7]):.3f} -> {min(t[8]):.3f} s)", flush=True)
