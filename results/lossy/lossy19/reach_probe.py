"""Every reach of the long fit on a cell, its residual by the context coder (step 22)
with the header: is the reach ranking (squared residual alone) missing a shorter one?

    python results/lossy/lossy19/reach_probe.py tgv_vorticity:1e-3
"""
import sys

import numpy as np
from cells import cells, quantised

from volpack.volume_codec import bounded_longfit as lf

for name, rel, a, e in cells(sys.argv[1]):
    for codec, q, best in quantised(a, e):
        ranked = lf.rank_reaches(np.ascontiguousarray(q, np.int64))
        print(f"{name} {rel} {q.shape} best other {best}", flush=True)
        for i, reach in enumerate(ranked):
            r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max), prune=True)
            head, _ = lf.encode_head(r, plan, w, context=True)
            body = len(lf.code_residuals(r))
            print(f"   rank {i} reach {reach}: head {len(head)} residual {body} "
                  f"total {len(head) + body}", flush=True)
