"""Where predictfit's decoder spends its time, on the streams capture.py kept (one
worker, warm): ``full`` the decoder's kernel; ``predict`` the prediction chain with the
voxels' values given (predictors, fitted blend, bias, texture, errors, the mix's slots,
no decisions); ``blend`` the same without the mix's slots (``residmix.contexts``);
``entropy`` the residuals' decisions alone with each voxel's contexts given (recorded
by a run of the decoder); ``loop`` the bare loop with the mask and the stores. ns per
coded voxel, best of ``--repeat`` CPU times, stages taking turns, summed over streams.
(The local fit is off in every stream of the corpus: not staged.)

    PYTHONPATH=. python results/lossless/pfd32/profile.py ct_head brainsmall --repeat 5
"""

import argparse
import csv
import inspect
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import capture  # noqa: E402

from volpack import volume_codec  # noqa: E402,F401
from volpack._jit import kernel  # noqa: E402
from volpack.entropy.common import stream_bytes  # noqa: E402
from volpack.entropy.rangecoder import open_stream  # noqa: E402
from volpack.volume_codec import localfit  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402


def kernel_args(item):
    data, shape, lo, hi, mask, fill, low, tex, mix, local, plane = item
    th = np.frombuffer(data, dtype="<u4", count=pf.NCLS - 1).astype(np.int64)
    cf = np.frombuffer(data, dtype="<i2", count=pf.NCLS * pf.NFIT, offset=4 * (pf.NCLS - 1)).astype(np.int64)
    buf = stream_bytes(data[pf.HEAD:], "predictive")
    n = int(np.prod(shape))
    mk = np.zeros(n, np.uint8) if mask is None else np.ascontiguousarray(mask, np.uint8).reshape(-1)
    return (buf, mk, np.int64(fill - lo), cf, th, np.array(shape, np.int64), np.int64(hi - lo),
            pf._nlow(low), np.int64(tex), np.int64(plane), np.int64(mix))


# Either tree: the branch's residual decoder takes the weights' bound as a constant
# (left out, as its fast kernel does), the base's has it always.
if "clamp" in inspect.signature(pf.get_residual_mix.py_func).parameters:
    @kernel(inline=True)
    def _residual(data, models, ctx, sctx, q, code, rng, pos, aux, mx):
        return pf.get_residual_mix(data, models, ctx, sctx, q, code, rng, pos, aux, mx, False)
else:
    _residual = pf.get_residual_mix


@kernel(nrt=False)
def _record(data, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, v, err, perr, bias_sum, bias_cnt, bias,
            models, aux, lw, cx):
    """The decoder (no local fit), keeping each voxel's (ctx, sctx, q, mx0..3) in ``cx``."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    code, rng, pos = open_stream(data)
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                r = cur + y * nx + x
                if mk[i]:
                    v[i] = fill
                    held = pf._skip(err, perr, r, fill)
                    i += 1
                    continue
                pred, ctx, bctx, sctx, mx, q0, q1, q2, q3, q4, q5, pb, lq = pf._predict_mix(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held, tex, plane,
                    mix, localfit.NONE, lw,
                )
                q = pf._low_class(pred, nlow)
                b = 7 * i
                cx[b], cx[b + 1], cx[b + 2] = ctx, sctx, q
                cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6] = mx
                res, code, rng, pos = _residual(data, models, ctx, sctx, q, code, rng, pos, aux, mx)
                val = pred + res
                v[i] = val
                held = pf._learn(err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
                i += 1
    return 0


@kernel(nrt=False)
def _predict_only(vals, mk, fill, cf, th, shape, hi, nlow, tex, plane, mix, v, err, perr, bias_sum, bias_cnt,
                  bias, lw):
    """The prediction chain with the values given; returns a checksum."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    z0 = np.int64(0)
    held = (z0, z0, z0, z0, z0, z0, z0, z0)
    i = 0
    acc = np.int64(0)
    for z in range(nz):
        cur = (z & 1) * sz
        prev = sz - cur
        for y in range(ny):
            for x in range(nx):
                r = cur + y * nx + x
                if mk[i]:
                    v[i] = fill
                    held = pf._skip(err, perr, r, fill)
                    i += 1
                    continue
                pred, ctx, bctx, sctx, mx, q0, q1, q2, q3, q4, q5, pb, lq = pf._predict_mix(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held, tex, plane,
                    mix, localfit.NONE, lw,
                )
                acc += pred + ctx + sctx + pf._low_class(pred, nlow) + mx[0] + mx[1] + mx[2] + mx[3]
                val = vals[i]
                v[i] = val
                held = pf._learn(err, perr, r, val, pred, bctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
                i += 1
    return acc


@kernel(nrt=False)
def _entropy_only(data, mk, cx, n, models, aux):
    """The residuals' decisions with each voxel's contexts given; returns a checksum."""
    code, rng, pos = open_stream(data)
    acc = np.int64(0)
    for i in range(n):
        if mk[i]:
            continue
        b = 7 * i
        mx = (cx[b + 3], cx[b + 4], cx[b + 5], cx[b + 6])
        res, code, rng, pos = _residual(data, models, cx[b], cx[b + 1], cx[b + 2], code, rng, pos, aux, mx)
        acc += res
    return acc


@kernel(nrt=False)
def _loop_only(vals, mk, fill, shape, v, err):
    nz, ny, nx = shape[0], shape[1], shape[2]
    sz = ny * nx
    i = 0
    for z in range(nz):
        cur = (z & 1) * sz
        for y in range(ny):
            for x in range(nx):
                r = cur + y * nx + x
                if mk[i]:
                    v[i] = fill
                    err[r] = 0
                    i += 1
                    continue
                v[i] = vals[i]
                err[r] = vals[i]
                i += 1
    return 0


def stages(item):
    a = kernel_args(item)
    shape = item[1]
    n = int(np.prod(shape))
    v = np.empty(n, np.int64)
    cx = np.zeros(7 * n, np.int64)
    ws = pf._workspace(shape)
    _record(*a, v, *ws[:8], cx)
    assert np.array_equal(pf.decode(*item).reshape(-1) - item[2], v)
    vals = v.copy()

    def full():  # (the whole of predictfit.decode: its Python is a few us a stream)
        return pf.decode(*item)

    def predict(mix=a[10]):
        err, perr, bs, bc, bias, _, _, lw = pf._workspace(shape)[:8]
        return _predict_only(vals, *a[1:10], np.int64(mix), np.empty(n, np.int64), err, perr, bs, bc, bias, lw)

    def entropy():
        ws = pf._workspace(shape)[:8]
        return _entropy_only(a[0], a[1], cx, n, ws[5], ws[6])

    def loop():
        return _loop_only(vals, a[1], a[2], a[5], np.empty(n, np.int64), pf._workspace(shape)[0])

    fns = {"full": full, "predict": predict, "blend": lambda: predict(0), "entropy": entropy, "loop": loop}
    return fns, int(n - a[1].sum())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("items", nargs="+")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    rows = []
    for name in args.items:
        items = [stages(it) for it in capture.streams(name)]
        names = list(items[0][0])
        best = {s: np.full(len(items), np.inf) for s in names}
        for k in range(args.repeat):
            order = names if k % 2 == 0 else names[::-1]
            for j, (fns, _) in enumerate(items):
                for s in order:
                    t = time.process_time()
                    fns[s]()
                    best[s][j] = min(best[s][j], time.process_time() - t)
        coded = sum(c for _, c in items)
        row = {"item": name, "streams": len(items), "coded_voxels": coded}
        row.update({f"{s}_ns": round(1e9 * best[s].sum() / coded, 1) for s in names})
        row["load"] = f"{os.getloadavg()[0]:.1f}"
        print(row, flush=True)
        rows.append(row)
    if args.out:
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
