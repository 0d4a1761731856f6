"""A parametric prior for the predictive stream's models (issue 20, step 2), measured
without a format change: ``predictfit._workspace`` (which the encoder and the decoder
both call for fresh states) is patched to start the models of the zero flag and of the
unary length bits where a two-sided geometric residual implies, its mean |r| taken from
the context's activity class (``alpha`` x the class's mid activity + ``beta``, times
``spread`` per spread class above 0); the use count starts at ``n0`` (how strong the
prior is). Signs, mantissa bits, the low-value models and the mix's model 4 stay at one
half. The mix's models 2 (wider activity) and 3 (activity in the slice before) get the
same prior from their own activity sums (``k23`` times the alpha; 0: none). Every file is decoded back (same patch) and
compared.

    python results/lossless/prime27/prior.py NAMES --grid "alpha,beta,spread,n0[,cap[,k23]];..." [--effort max]
"""

import argparse
import sys
import time

import numpy as np

sys.path[:0] = [".", "scripts"]  # this worktree's volpack (run from its root)
from datasets import load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402
from volpack.volume_codec import residmix as rm  # noqa: E402
from volpack.volume_codec.predict import NACT, NLEN, NSPREAD, activity_class  # noqa: E402

REAL = pf._workspace


def mid_activity() -> np.ndarray:
    """The mean activity of each class (activities up to 2^22 taken as equally likely
    within a class: its middle); the classes as :func:`.predict.activity_class` makes
    them (checked against it)."""
    a = np.arange(1 << 22)
    cls = np.empty(a.size, np.int64)
    small = a < 4
    b = np.floor(np.log2(a | 4)).astype(np.int64) + 1
    cls[~small] = np.minimum(2 * b[~small] - 2 + ((a[~small] >> (b[~small] - 2)) & 1), NACT - 1)
    cls[small] = a[small]
    assert all(cls[x] == activity_class(x) for x in range(0, 1 << 22, 997))
    return np.array([a[cls == k].mean() if (cls == k).any() else a[-1] for k in range(NACT)])


MID = mid_activity()


def geometric_probs(m: float) -> tuple[float, np.ndarray]:
    """P(r = 0) and P(length bit j is 0 | reached) for a two-sided geometric residual
    of mean |r| = m (within 1 - CAP..CAP, by :func:`state`)."""
    m = max(m, 1e-3)
    theta = (np.sqrt(1 + m * m) - 1) / m  # E|r| = 2 theta / (1 - theta^2)
    p0 = (1 - theta) / (1 + theta)
    j = np.arange(NLEN)
    go_on = np.where(j == 0, theta, theta ** (2.0 ** np.maximum(j - 1, 0)))
    return p0, 1 - go_on


CAP = [0.9]  # no prior probability beyond this of either value (residuals' tails are heavy)
K23 = [1.0]  # models 2-3's alpha over model 1's (0: not primed)


def state(p: float, n0: int) -> int:
    p = min(max(p, 1 - CAP[0]), CAP[0])
    q = int(round(p * 65536))
    return (min(max(q, 64), 65536 - 64) << 8) | n0


def primed(alpha, beta, spread, n0):
    """Fresh states with the prior (models of predictfit, models 2-3 of the mix)."""
    models = np.full(pf.N_MODELS_LOW, pf.MODEL_INIT, dtype=np.uint32)
    aux = rm.workspace()
    for a in range(NACT):
        for w in range(NSPREAD):
            ctx = a * NSPREAD + w
            p0, plen = geometric_probs((alpha * MID[a] + beta) * spread**w)
            models[pf.M_ZERO + 2 * ctx : pf.M_ZERO + 2 * ctx + 2] = state(p0, n0)
            for j in range(NLEN):
                models[pf.M_LEN + ctx * NLEN + j] = state(plen[j], n0)
            if K23[0]:
                m2 = (K23[0] * alpha * 4 / 6 * MID[a] + beta) * spread**w
                _slot_prior(aux, rm.B_WIDE + ctx * rm.NSLOT, m2, n0)
        if K23[0]:
            _slot_prior(aux, rm.B_UP + a * rm.NSLOT, K23[0] * alpha * 4 / 4.5 * MID[a] + beta, n0)
    return models, aux


def _slot_prior(aux, base, m, n0):
    p0, plen = geometric_probs(m)
    aux[base + rm.S_ZERO : base + rm.S_ZERO + 4] = state(p0, n0)
    for j in range(rm.NLENS):
        aux[base + rm.S_LEN + j] = state(plen[j], n0)


def patched(models, aux):
    def ws(shape):
        out = list(REAL(shape))
        out[5], out[6] = models.copy(), aux.copy()
        return tuple(out)

    return ws


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("names", nargs="+")
    ap.add_argument("--grid", default="0.25,0.3,1.3,2")
    ap.add_argument("--effort", default=None)
    ap.add_argument("--no-check", action="store_true")
    a = ap.parse_args()
    opts = {"effort": a.effort} if a.effort else {}
    grid = [tuple(float(x) for x in g.split(",")) for g in a.grid.split(";")]
    grid = [g + (0.9, 1.0)[len(g) - 4 :] for g in grid]
    print(
        "volume,voxels,alpha,beta,spread,n0,cap,k23,bytes,base_bytes,saving_pct,seconds", flush=True
    )
    for name in a.names:
        vol, _, _ = load(name)
        pf._workspace = REAL
        base = len(api.compress_array(vol, **opts))
        for alpha, beta, spread, n0, cap, k23 in grid:
            CAP[0], K23[0] = cap, k23
            pf._workspace = patched(*primed(alpha, beta, spread, int(n0)))
            t = time.perf_counter()
            blob = api.compress_array(vol, **opts)
            dt = time.perf_counter() - t
            if not a.no_check:
                assert np.array_equal(api.decompress_array(blob), vol), name
            n = len(blob)
            print(
                f"{name},{vol.size},{alpha},{beta},{spread},{int(n0)},{cap},{k23},{n},{base},"
                f"{100 * (base - n) / base:.3f},{dt:.1f}",
                flush=True,
            )
        pf._workspace = REAL


if __name__ == "__main__":
    main()
