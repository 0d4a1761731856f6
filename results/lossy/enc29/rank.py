"""Estimates against real sizes, per brick and path, of the default-effort lossy encoder
(what a selection by estimate would rank on). One row per (cell, path, variant):

    PYTHONPATH=. python results/lossy/enc29/rank.py OUT.csv [FIELDS]

Estimates (bytes): long = zeroth-order entropy of the long fit's residual per reach;
int = the static coding's estimate per walk; cdf = the level choice's cost at the probe
step; qv = zeroth-order entropy of the quantised voxels' 3-D Lorenzo residual."""

import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench import TUNE, load_field  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import bounded_interp as bi  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402

ROWS = []
CELL = [""]


def entropy_bytes(r):
    _, n = np.unique(r, return_counts=True)
    return float(-(n * np.log2(n / r.size)).sum()) / 8


def lorenzo(q):
    q = q.astype(np.int64)
    p = np.zeros_like(q)
    p[1:] += q[:-1]
    p[:, 1:] += q[:, :-1]
    p[:, :, 1:] += q[:, :, :-1]
    p[1:, 1:] -= q[:-1, :-1]
    p[1:, :, 1:] -= q[:-1, :, :-1]
    p[:, 1:, 1:] -= q[:, :-1, :-1]
    p[1:, 1:, 1:] += q[:-1, :-1, :-1]
    return q - p


def row(path, variant, est, real, sec):
    ROWS.append(
        (CELL[0], path, variant, round(est, 1) if est is not None else "", real, round(sec, 4))
    )


def analyse(self, x, mask):
    clean = x if mask is None else lossy.fill_masked(x, mask)
    q = self._quantize(clean)
    if mask is not None:
        q = lossy.fill_masked(q, mask)
    t = time.process_time()
    e = entropy_bytes(lorenzo(q))
    row("qv", "lorenzo_est", e, "", time.process_time() - t)
    t = time.process_time()
    w = self._inner().encode(q)
    row("qv", "wav", None, len(w), time.process_time() - t)
    t = time.process_time()
    p = self._predictive().encode(q)
    row("qv", "pred", None, len(p), time.process_time() - t)
    if x.dtype.kind == "f" and x.size >= 64 and not self._exact:
        g = clean.astype(np.float64)
        for kind, perms in bi.TRIED:
            for perm in perms:
                t = time.process_time()
                rec, sym, ctx, raw, abin, adx = bi._run(g, self.step, perm, kind)
                est = (bi._estimate(sym, ctx) + 8 * raw.size) / 8
                t1 = time.process_time()
                body = bi.encode_with_retry(
                    lambda out, abin=abin, adx=adx: bi._encode_adaptive(
                        abin, adx, bi._fresh_models(), out
                    ),
                    g.size,
                    (2, 20),
                    coder="bin",
                )
                row("int", f"{kind}{''.join(map(str, perm))}", est, len(body), t1 - t)
                row(
                    "int_adapt",
                    f"{kind}{''.join(map(str, perm))}",
                    est,
                    len(body),
                    time.process_time() - t1,
                )
    if x.dtype.kind == "f" and q.ndim == 3 and min(q.shape) >= 4 and q.size >= 4096:
        qmax = int(np.iinfo(q.dtype).max)
        t = time.process_time()
        ranked = lf.rank_reaches(np.ascontiguousarray(q, np.int64))
        row("long", "rank", None, "", time.process_time() - t)
        for i, reach in enumerate(ranked[:4] + [min(lf.reach_choices(q.shape), key=sum)]):
            name = f"{i}:{'-'.join(map(str, reach))}"
            t = time.process_time()
            r, plan, weights = lf.residuals(q, reach, qmax, prune=True)
            est = lf.estimate_bits(r) / 8
            row("long_fit", name, est, "", time.process_time() - t)
            t = time.process_time()
            d = lf.encode_head(r, plan, weights, context=True)[0] + lf.code_residuals(r)
            row("long_ctx", name, est, len(d), time.process_time() - t)
            t = time.process_time()
            b = lf.code_static(r)
            d = (
                lf.encode_head(r, plan, weights, code=lf.STATIC_CODED)[0] + b
                if b is not None
                else b""
            )
            row("long_static", name, est, len(d), time.process_time() - t)
            head = lf.encode_head(r, plan, weights)
            if head is not None:
                t = time.process_time()
                d = head[0] + self._inner().encode(head[1])
                row("long_wav", name, est, len(d), time.process_time() - t)
                t = time.process_time()
                d = head[0] + self._predictive().encode(head[1])
                row("long_pred", name, est, len(d), time.process_time() - t)


orig = lossy.BoundedCodec._encode_masked


def wrapped(self, x, mask):
    analyse(self, x, mask)
    t = time.process_time()
    out = orig(self, x, mask)
    row("kept", "", None, len(out[0]), time.process_time() - t)
    return out


lossy.BoundedCodec._encode_masked = wrapped

if __name__ == "__main__":
    names = sys.argv[2].split(",") if len(sys.argv) > 2 else TUNE
    for name in names:
        x = load_field(name)
        lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
        for rel in (1e-2, 1e-3, 1e-4, 1e-5):
            CELL[0] = f"{name}@{rel:g}"
            api.compress_array(x, max_error=rel * (hi - lo), workers=1)
            print(CELL[0], file=sys.stderr, flush=True)
    with open(sys.argv[1], "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["cell", "path", "variant", "est_bytes", "real_bytes", "cpu_s"])
        w.writerows(ROWS)
