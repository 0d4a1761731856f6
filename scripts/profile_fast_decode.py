"""Where the ``fast`` decoder's time goes, per voxel, on the 64^3 bricks of real volumes.

For every brick (values coded by :func:`volpack.volume_codec.fastpredict.encode` with
its own range, no palette), in one process, CPU seconds, best of ``--repeat``:

* ``full``: :func:`fastpredict.decode` (head, tables, the voxel loop);
* ``head``: the head alone (tables read into the decoder's look-ups, stream copied);
* ``entropy``: the same symbols (tokens and raw bits) decoded with their contexts given
  (the encoder's sequence), no prediction, no context computation: the rANS chain and the
  bit reader as the decoder runs them (:func:`fastpredict.take_symbol`);
* ``rans``: the tokens alone, no raw bits;
* ``predict``: the prediction chain alone (MED inside the slice, plus the 3-D correction
  of the brick's predictor) with the residuals given, every voxel predicted;

so ``full - head - entropy - predict`` is what the rest costs (contexts, run and row
logic, edges, branches). ns a voxel, the sum over bricks divided by their voxels.

    python scripts/profile_fast_decode.py ct_head mri_ch2better brainsmall --repeat 5
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_decode import _cpu_best  # noqa: E402
from bench_workers import append_csv  # noqa: E402

from volpack._jit import kernel  # noqa: E402
from volpack.entropy import rans  # noqa: E402
from volpack.volume_codec import fastpredict as fp  # noqa: E402


@kernel(nrt=False)
def _entropy_kernel(data, words, syms, info, ctx, tok, raw):
    """Decode ``ctx.size`` symbols with the given contexts: the sum of their values
    (``raw``: with the raw bits, else the tokens only)."""
    x0, x1, pos = rans.open_states(data)
    reader = (np.uint64(0), np.int64(0), np.int64(0))
    total = np.int64(0)
    if raw:
        for k in range(ctx.size):
            ue, pos, x0, x1, reader = fp.take_symbol(
                syms, info, np.int64(ctx[k]), data, pos, x0, x1, words, reader, tok
            )
            total += ue
    else:
        for k in range(ctx.size):
            t, x0, pos = rans.decode_symbol_split(data, x0, pos, np.int64(ctx[k]) << 12, syms, info)
            x0, x1 = x1, x0
            total += t
    return total


@kernel(nrt=False)
def _predict_kernel(v, e, shape, pid, lo, hi):
    """The prediction chain with the residuals ``e`` given (as the decoder's edges and
    inside), every voxel: the sum of the voxels."""
    nz, ny, nx = shape[0], shape[1], shape[2]
    sy, sz = nx, ny * nx
    mid = (lo + hi) >> 1
    i = 0
    total = np.int64(0)
    for z in range(nz):
        pz = pid if z > 0 else 0
        for y in range(ny):
            for x in range(nx):
                if y > 0 and 0 < x < nx - 1:  # the inside, as the decoder runs it
                    k = i - sy
                    p = fp._med(np.int64(v[i - 1]), np.int64(v[k]), np.int64(v[k - 1]))
                    if pz != 0:
                        j = i - sz
                        m = fp._med(np.int64(v[j - 1]), np.int64(v[j - sy]), np.int64(v[j - sy - 1]))
                        p = fp._correct(p, v[j] - m, pz)
                    p = min(max(p, lo), hi)
                else:
                    p = min(max(fp._predict(v, i, z, y, x, sy, sz, pz, mid), lo), hi)
                w = p + e[i]
                v[i] = w
                total += w
                i += 1
    return total


def profile_brick(b: np.ndarray, repeat: int) -> tuple[dict, str]:
    """The times (s) of each part on one brick, and its mode."""
    lo, hi = int(b.min()), int(b.max())
    stream = fp.encode(b, lo, hi)
    back = fp.decode(stream, b.shape, lo, hi)
    assert np.array_equal(back, b)
    choice = stream[0]
    pid, cid = choice & 3, (choice & ~(fp.RUNS | fp.ROWS)) >> 2
    runs, rows = bool(choice & fp.RUNS), bool(choice & fp.ROWS)
    flat = np.ascontiguousarray(b.reshape(-1).astype(np.int64))
    n = flat.size
    shape = np.array(b.shape, dtype=np.int64)
    toks = np.empty(2 * n + b.shape[0] * b.shape[1], dtype=np.uint8)
    ctxs = np.empty_like(toks)
    counts = np.zeros((fp.ROW_KIND + fp.ROW_TABLES, rans.MAX_SYMBOLS), dtype=np.int64)
    bits = np.empty(4 * n + 16, dtype=np.uint8)
    ring = np.zeros(2 * b.shape[1] * b.shape[2], dtype=np.int64)
    _, nsym, _, _ = fp._tokens_kernel(
        flat, shape, np.int64(lo), np.int64(hi), pid, cid, runs, rows, toks, ctxs, ring,
        counts, bits,
    )  # fmt: skip
    buf = np.frombuffer(stream, dtype=np.uint8)
    ntab = fp.NCLASS + 2 + fp.ROW_TABLES
    syms = np.empty((ntab, rans.TOTAL), dtype=np.uint8)
    info = np.empty((ntab, rans.MAX_SYMBOLS), dtype=np.uint32)
    act = np.empty(fp.ACTIVITY.size, dtype=np.uint8)
    data = np.empty(buf.size + 2, dtype=np.uint8)
    words = np.empty(buf.size // 4 + 2, dtype=np.uint32)
    kinds = np.zeros(b.shape[0] * b.shape[1], dtype=np.uint8)
    ring32 = np.zeros(ring.size, dtype=np.int32)

    def head():
        return fp._head_kernel(buf, syms, info, act, data, words, ring32, kinds)

    status, _, nctx, nbytes, nraw = head()
    assert status == 0
    ctx = ctxs[:nsym].astype(np.int64)
    ctx = np.where(ctx >= fp.NCLASS, ctx - fp.NCLASS + nctx, np.minimum(ctx, nctx - 1))
    ctx = ctx.astype(np.uint8)
    d, w = data[: nbytes + 2], words[: (nraw + 3) // 4 + 1]
    fs, fi = syms.reshape(-1), info.reshape(-1)
    # the decoded values of the symbols: the sum must match the encoder's
    want = int(_entropy_kernel(d, w, fs, fi, ctx, fp.TOK, True))
    expect_tok = int(toks[:nsym].astype(np.int64).sum())
    assert int(_entropy_kernel(d, w, fs, fi, ctx, fp.TOK, False)) == expect_tok
    e = (flat - (lo + hi) // 2) // 8  # residuals to add (their values do not change the
    v = np.zeros(n, dtype=np.int64)  # chain's work: the cost of the chain is what is timed)
    parts = {
        "full": lambda: fp.decode(stream, b.shape, lo, hi, reuse=True),
        "head": head,
        "entropy": lambda: _entropy_kernel(d, w, fs, fi, ctx, fp.TOK, True),
        "rans": lambda: _entropy_kernel(d, w, fs, fi, ctx, fp.TOK, False),
        "predict": lambda: _predict_kernel(v, e, shape, pid, np.int64(lo), np.int64(hi)),
    }
    times = {k: _cpu_best(fn, repeat)[0] for k, fn in parts.items()}
    times["symbols"] = nsym
    times["sum"] = want
    mode = f"{fp.PREDICTORS[pid]}-{fp.CONTEXTS[cid]}" + "+runs" * runs + "+rows" * rows
    return times, mode


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless" / "lossless11")
    args = ap.parse_args(argv)
    import datasets

    from volpack.volume_codec import bricks

    rows = []
    for name in args.datasets:
        a, _, _ = datasets.load(name)
        a = np.ascontiguousarray(a)
        tot = dict.fromkeys(("full", "head", "entropy", "rans", "predict"), 0.0)
        nvox = nsym = 0
        modes: dict[str, int] = {}
        grid = bricks.grid_shape(a.shape, (64, 64, 64))
        for node in range(int(np.prod(grid))):
            b = np.ascontiguousarray(a[bricks.brick_slices(a.shape, (64, 64, 64), node)])
            if b.min() == b.max():
                continue
            t, mode = profile_brick(b, args.repeat)
            for k in tot:
                tot[k] += t[k]
            nvox += b.size
            nsym += t["symbols"]
            modes[mode] = modes.get(mode, 0) + 1
        row = {"dataset": name, "dtype": str(a.dtype), "coded_voxels": nvox, "symbols": nsym}
        row.update({f"{k}_ns": round(1e9 * v / nvox, 2) for k, v in tot.items()})
        row["rest_ns"] = round(row["full_ns"] - row["head_ns"] - row["entropy_ns"] - row["predict_ns"], 2)
        row["full_mb_s"] = round(nvox * a.itemsize / 1e6 / tot["full"], 1)
        row["modes"] = "; ".join(f"{k} {v}" for k, v in sorted(modes.items()))
        row["load"] = f"{os.getloadavg()[0]:.1f}"
        print(row, flush=True)
        rows.append(row)
    append_csv(rows, args.out / "fast_profile.csv")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
