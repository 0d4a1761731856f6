"""Probe: a spread part in the context coder's context (3 x activity class + g, g from
the face neighbours' mean magnitude against the other nine steps'), on the long fit's
residual at the shortest reach; against today's contexts (step 22), coded by the kernel
and by the probe.

    python results/lossy/lossy19/spread_probe.py tgv_pressure:1e-5,tas_monthly:1e-5
"""
import sys

import numpy as np
from cells import cells, quantised
from ctx_probe import coded

from volpack.volume_codec import bounded_longfit as lf

for name, rel, a, e in cells(sys.argv[1]):
    for codec, q, best in quantised(a, e):
        reach = lf.tried_reaches(np.ascontiguousarray(q, np.int64))[-1]
        r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max), prune=True)
        print(f"{name} {rel} reach {reach}: today {len(lf.code_residuals(r))} "
              f"(probe {coded(r, '12', 'W|NU', 1)}), with spread "
              f"{coded(r, '12', 'W|NU', 1, spread=True)}", flush=True)
