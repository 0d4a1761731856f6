"""The long fit's residual (the best-ranked reaches) coded by the adaptive binary coder
(predictfit.put_residual) in contexts of the causal residuals' magnitudes: which
neighbours, sign contexts, the faces' sums scaled or not; against the lossless codec's
wavelet. The numbers in ctx_code*.txt came from one-off versions of this probe.

    python results/lossy/lossy19/ctx_probe.py tgv_pressure:1e-5,tas_monthly:1e-5
"""
import sys

import numpy as np
from cells import cells, quantised

from volpack.entropy.common import encode_with_retry
from volpack.volume_codec import bounded_interp as bi
from volpack.volume_codec import bounded_longfit as lf
from volpack.volume_codec.predict import activity_class

NB = {
    "3": ([(0, 0, 1), (0, 1, 0), (1, 0, 0)], [2, 2, 2]),
    "7": ([(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (0, 0, 2), (0, 2, 0)],
          [2, 2, 2, 1, 1, 1, 1]),
    "12": ([tuple(int(v) for v in s[:3]) for s in lf._ACT], [int(s[3]) for s in lf._ACT]),
}  # fmt: skip


def coded(r, nb, sign, scaled, spread=False):
    nz, ny, nx = r.shape
    pad, one = np.pad(r, 2), np.pad(np.ones(r.shape, np.int64), 2)
    P = lambda v, dz, dy, dx: v[2 - dz:2 - dz + nz, 2 - dy:2 - dy + ny, 2 - dx:2 - dx + nx]  # noqa: E731
    steps, wts = NB[nb]
    act = sum(w * np.abs(P(pad, *o)) for o, w in zip(steps, wts))
    if scaled:
        ws = sum(w * P(one, *o) for o, w in zip(steps, wts))
        act = np.where(ws > 0, act * 16 // np.maximum(ws, 1), 0)
    u = np.unique(act)
    ctx = np.array([activity_class(int(v)) for v in u])[np.searchsorted(u, act)]
    if spread:  # 3 x class + the face neighbours' mean magnitude against the rest's
        f = sum(np.abs(P(pad, *o)) for o in steps[:3]) * 3
        e = sum(np.abs(P(pad, *o)) for o in steps[3:])
        ctx = np.minimum(3 * ctx + np.where(2 * f < e, 0, np.where(f < 2 * e, 1, 2)), 143)
    W, N, U = P(pad, 0, 0, 1), P(pad, 0, 1, 0), P(pad, 1, 0, 0)
    sg = lambda v: np.where(v > 0, 1, np.where(v < 0, 2, 0))  # noqa: E731
    s = {"none": 0 * W, "W": sg(W), "WNU": sg(W + N + U), "W|NU": (W > 0) + 2 * (N + U > 0),
         "W|N": (W > 0) + 2 * (N > 0)}[sign]  # fmt: skip
    adx = (4 * ctx + s).reshape(-1).astype(np.int64)
    flat = r.reshape(-1).astype(np.int64)
    return len(encode_with_retry(
        lambda out: bi._encode_adaptive(flat, adx, bi._fresh_models(), out), r.size, (2, 20),
        coder="bin"))  # fmt: skip


if __name__ == "__main__":
    for name, rel, a, e in cells(sys.argv[1]):
        for codec, q, best in quantised(a, e):
            for reach in lf.rank_reaches(np.ascontiguousarray(q, np.int64))[:2]:
                r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max))
                head, res = lf.encode_head(r, plan, w)
                print(f"{name} {rel} {q.shape} best {best} reach {reach} head {len(head)} "
                      f"wavelet {len(codec._inner().encode(res))}", flush=True)
                for nb, sign, scaled in [("3", "none", 0), ("7", "none", 0), ("12", "none", 0),
                                         ("12", "W", 0), ("12", "WNU", 0), ("12", "W|N", 0),
                                         ("12", "W|NU", 0), ("12", "W|NU", 1)]:  # fmt: skip
                    print(f"   steps {nb:2s} sign {sign:5s} scaled {scaled}: "
                          f"{coded(r, nb, sign, scaled)}", flush=True)
