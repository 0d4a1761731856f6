"""Decoding time of the long fit's stages on a cell: the context-coded residual (step
22), the wavelet-coded one, and the walk; best of 5, CPU seconds, one process.

    python results/lossy/lossy19/decode_stages.py tgv_vorticity:1e-3
"""
import sys
import time

import numpy as np
from cells import cells, quantised

from volpack.volume_codec import bounded_longfit as lf


def best(f, n=5):
    t = []
    for _ in range(n):
        t0 = time.process_time()
        f()
        t.append(time.process_time() - t0)
    return min(t)


for name, rel, a, e in cells(sys.argv[1]):
    for codec, q, _ in quantised(a, e):
        reach = lf.tried_reaches(np.ascontiguousarray(q, np.int64))[-1]
        r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max), prune=True)
        ctx = lf.code_residuals(r)
        head, res = lf.encode_head(r, plan, w)
        wav = codec._inner().encode(res)
        lf.decode_residuals(ctx, r.shape)
        flat = r.reshape(-1).copy()
        out = np.empty(flat.size, np.int64)
        top = int(np.iinfo(q.dtype).max)
        lf.walk(out, flat, plan, w, top, True)
        mb = a.nbytes / 1e6
        t_ctx = best(lambda: lf.decode_residuals(ctx, r.shape))
        t_wav = best(lambda: codec._inner().decode(wav, r.shape, res.dtype))
        t_walk = best(lambda: lf.walk(out, flat, plan, w, top, True))
        print(f"{name} {rel} reach {reach}: context residual {len(ctx)} B {1e3 * t_ctx:.1f} ms "
              f"({mb / t_ctx:.0f} MB/s of the field), wavelet {len(wav)} B {1e3 * t_wav:.1f} ms, "
              f"walk {1e3 * t_walk:.1f} ms", flush=True)
