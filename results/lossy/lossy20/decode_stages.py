"""Decoding time of the long fit's residual codings on a cell: the context-coded residual
(type 3, step 22), the static one (type 4, step 23), the wavelet's, and the walk; best
of 7, CPU seconds, one process, interleaved.

    python results/lossy/lossy20/decode_stages.py tgv_vorticity:1e-3
"""
import sys
import time

import numpy as np
from common import residuals

from volpack.volume_codec import bounded_longfit as lf

for name, rel, a, codec, q, (r, plan, w) in residuals(sys.argv[1]):
    ctx = lf.code_residuals(r)
    st = lf.code_static(r)
    head, res = lf.encode_head(r, plan, w)
    wav = codec._inner().encode(res)
    assert np.array_equal(lf.decode_static(st, r.shape), r.reshape(-1))
    flat = r.reshape(-1).copy()
    out = np.empty(flat.size, np.int64)
    top = int(np.iinfo(q.dtype).max)
    runs = {
        "type3": lambda: lf.decode_residuals(ctx, r.shape),
        "type4": lambda: lf.decode_static(st, r.shape),
        "wavelet": lambda: codec._inner().decode(wav, r.shape, res.dtype),
        "walk": lambda: lf.walk(out, flat, plan, w, top, True),
    }
    for f in runs.values():
        f()
    t = {k: [] for k in runs}
    for i in range(7):
        for k in (list(runs) if i % 2 else list(runs)[::-1]):
            t0 = time.process_time()
            runs[k]()
            t[k].append(time.process_time() - t0)
    mb = a.nbytes / 1e6
    sizes = {"type3": len(ctx), "type4": len(st), "wavelet": len(wav), "walk": 0}
    print(f"{name} {rel} reach {plan.reach}: " + ", ".join(
        f"{k} {sizes[k]} B {1e3 * min(v):.1f} ms ({mb / min(v):.0f} MB/s)"
        for k, v in t.items()), flush=True)
