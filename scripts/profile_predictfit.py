"""Where the default decoder's time goes: :mod:`volpack.volume_codec.predictfit`'s
``_decode_kernel`` split into stages, on the version-2 predictive streams of real volumes.

Each volume is compressed with the defaults (``api.compress_array``) and decoded once with
``predictfit.decode`` wrapped, which keeps every version-2 stream with its shape, range,
mask and flags. Then, best of ``--repeat`` CPU seconds per stream, stages taking turns:

* ``full``: the decoder's kernel as it is;
* ``predict``: the prediction chain alone (predictors, blend, contexts, errors and bias
  upkeep), the voxels' values given instead of decoded;
* ``entropy``: the residuals' binary decisions alone, each voxel's contexts given (recorded
  from a run of the decoder);
* ``loop``: the loop over voxels with the mask and the stores, nothing else.

ns per coded (unmasked) voxel, summed over the volume's streams.

    PYTHONPATH=. python scripts/profile_predictfit.py ct_head mri_ch2better --repeat 5
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from volpack._jit import kernel  # noqa: E402
from volpack.entropy.common import stream_bytes  # noqa: E402
from volpack.entropy.rangecoder import open_stream  # noqa: E402
from volpack.volume_codec import predictfit as pf  # noqa: E402


def streams_of(name: str) -> list[tuple]:
    """The version-2 streams of volume ``name`` as ``predictfit.decode``'s arguments."""
    import datasets

    from volpack import api

    a, _, _ = datasets.load(name)
    blob = api.compress_array(np.ascontiguousarray(a))
    got = []
    real = pf.decode

    def keep(data, shape, lo, hi, mask=None, fill=0, low=False):
        got.append((bytes(data), tuple(shape), lo, hi, None if mask is None else mask.copy(), fill, low))
        return real(data, shape, lo, hi, mask, fill, low)

    pf.decode = keep
    try:
        api.decompress_array(blob, workers=1)
    finally:
        pf.decode = real
    return got


def kernel_args(item) -> tuple:
    """``predictfit._decode_kernel``'s arguments for one stream (as ``predictfit.decode``)."""
    data, shape, lo, hi, mask, fill, low = item
    th = np.frombuffer(data, dtype="<u4", count=pf.NCLS - 1).astype(np.int64)
    cf = np.frombuffer(data, dtype="<i2", count=pf.NCLS * pf.NFIT, offset=4 * (pf.NCLS - 1))
    buf = stream_bytes(data[pf.HEAD :], "predictive")
    n = int(np.prod(shape))
    mk = np.zeros(n, np.uint8) if mask is None else np.ascontiguousarray(mask, np.uint8).reshape(-1)
    fixed = (buf, mk, np.int64(fill - lo), cf.astype(np.int64), th, np.array(shape, dtype=np.int64))
    return fixed + (np.int64(hi - lo), pf._nlow(low))


@kernel(nrt=False)
def _record(data, mk, fill, cf, th, shape, hi, nlow, v, err, perr, bias_sum, bias_cnt, bias, models, cx):
    """The decoder, keeping each voxel's (ctx, sctx, q) in ``cx``."""
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
                pred, ctx, sctx, q0, q1, q2, q3, q4, q5 = pf._predict_kernel(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held
                )
                q = pf._low_class(pred, nlow)
                cx[3 * i], cx[3 * i + 1], cx[3 * i + 2] = ctx, sctx, q
                res, code, rng, pos = pf.get_residual(data, models, ctx, sctx, q, code, rng, pos)
                val = pred + res
                v[i] = val
                held = pf._learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
                i += 1
    return 0


@kernel(nrt=False)
def _predict_only(vals, mk, fill, cf, th, shape, hi, nlow, v, err, perr, bias_sum, bias_cnt, bias):
    """The prediction chain with the values given (``vals``); returns a checksum."""
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
                pred, ctx, sctx, q0, q1, q2, q3, q4, q5 = pf._predict_kernel(
                    v, cf, th, err, perr, i, r, r - cur + prev, z, y, x, ny, nx, hi, bias, held
                )
                acc += pred + ctx + sctx + pf._low_class(pred, nlow)
                val = vals[i]
                v[i] = val
                held = pf._learn(err, perr, r, val, pred, ctx, bias_sum, bias_cnt, bias, q0, q1, q2, q3, q4, q5)
                i += 1
    return acc


@kernel(nrt=False)
def _entropy_only(data, mk, cx, n, models):
    """The residuals' decisions with each voxel's contexts given; returns a checksum."""
    code, rng, pos = open_stream(data)
    acc = np.int64(0)
    for i in range(n):
        if mk[i]:
            continue
        res, code, rng, pos = pf.get_residual(data, models, cx[3 * i], cx[3 * i + 1], cx[3 * i + 2], code, rng, pos)
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
    """One stream's stage runners, each returning a fresh run's result."""
    args = kernel_args(item)
    shape = item[1]
    n = int(np.prod(shape))
    v = np.empty(n, np.int64)
    cx = np.zeros(3 * n, np.int64)
    ws = pf._workspace(shape)
    _record(*args, v, *ws, cx)
    check = np.empty(n, np.int64)
    assert pf._decode_kernel(*args, check, *pf._workspace(shape)) == 0 and np.array_equal(check, v)
    vals = v.copy()

    def full():
        return pf._decode_kernel(*args, np.empty(n, np.int64), *pf._workspace(shape))

    def predict():
        err, perr, bs, bc, bias, _ = pf._workspace(shape)
        return _predict_only(vals, *args[1:8], np.empty(n, np.int64), err, perr, bs, bc, bias)

    def entropy():
        return _entropy_only(args[0], args[1], cx, n, pf._workspace(shape)[-1])

    def loop():
        return _loop_only(vals, args[1], args[2], args[5], np.empty(n, np.int64), pf._workspace(shape)[0])

    coded = int(n - args[1].sum())
    return {"full": full, "predict": predict, "entropy": entropy, "loop": loop}, coded


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    rows = []
    for name in args.datasets:
        items = [stages(it) for it in streams_of(name)]
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
        row = {"dataset": name, "streams": len(items), "coded_voxels": coded}
        row.update({f"{s}_ns": round(1e9 * best[s].sum() / coded, 1) for s in names})
        row["load"] = f"{os.getloadavg()[0]:.1f}"
        print(row, flush=True)
        rows.append(row)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
