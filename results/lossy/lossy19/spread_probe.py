"""Probe: a spread part in the context coder's context (3 x activity class + g, g from
the face neighbours' mean magnitude against the other nine steps'), on the long fit's
residual at the shortest reach; against today's contexts (step 22).

    python results/lossy/lossy19/spread_probe.py tgv_pressure:1e-5,tas_monthly:1e-5
"""
import sys

import numpy as np
from cells import cells, quantised

from volpack.entropy.common import encode_with_retry
from volpack.volume_codec import bounded_interp as bi
from volpack.volume_codec import bounded_longfit as lf
from volpack.volume_codec.predict import activity_class


def coded(r, spread):
    nz, ny, nx = r.shape
    pad, one = np.pad(np.abs(r), 2), np.pad(np.ones(r.shape, np.int64), 2)
    P = lambda v, dz, dy, dx: v[2 - dz:2 - dz + nz, 2 - dy:2 - dy + ny, 2 - dx:2 - dx + nx]  # noqa: E731
    steps = [tuple(int(v) for v in s[:3]) for s in lf._ACT]
    wts = [int(s[3]) for s in lf._ACT]
    act = sum(w * P(pad, *o) for o, w in zip(steps, wts))
    ws = sum(w * P(one, *o) for o, w in zip(steps, wts))
    act = np.where(ws > 0, act * 16 // np.maximum(ws, 1), 0)
    u = np.unique(act)
    ctx = np.array([activity_class(int(v)) for v in u])[np.searchsorted(u, act)]
    if spread:
        f = sum(P(pad, *o) for o in steps[:3]) * 3  # mean of 3, times 9
        e = sum(P(pad, *o) for o in steps[3:])  # mean of 9, times 9
        g = np.where(2 * f < e, 0, np.where(f < 2 * e, 1, 2))
        ctx = np.minimum(3 * ctx + g, 143)
    sr = np.pad(r, 2)
    W, N, U = P(sr, 0, 0, 1), P(sr, 0, 1, 0), P(sr, 1, 0, 0)
    s = (W > 0) + 2 * (N + U > 0)
    adx = (4 * ctx + s).reshape(-1).astype(np.int64)
    flat = r.reshape(-1).astype(np.int64)
    return len(encode_with_retry(
        lambda out: bi._encode_adaptive(flat, adx, bi._fresh_models(), out), r.size, (2, 20),
        coder="bin"))  # fmt: skip


for name, rel, a, e in cells(sys.argv[1]):
    for codec, q, best in quantised(a, e):
        reach = lf.tried_reaches(np.ascontiguousarray(q, np.int64))[-1]
        r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max), prune=True)
        print(f"{name} {rel} reach {reach}: today {len(lf.code_residuals(r))} "
              f"(probe {coded(r, False)}), with spread {coded(r, True)}", flush=True)
