"""Scratch (session 21, not kept): the bytes of the real ``effort="max"`` file with a
candidate estimate handed to predictfit's encoder in place of the local fit's (version 9
takes the local fit's estimates as an array, so the coder, contexts, blend weighting and
the keep-where-shorter choice are the real ones). Candidates: ``box`` (a per-brick
least-squares fit over a box of causal neighbours and a constant, in place of the local
fit), ``mean`` (its average with the local fit), ``stack`` (least squares over the box,
a constant and the local fit's estimate). The weights are counted at 2 bytes each on top
of the file, whether or not the encoder kept the stream.

    PYTHONPATH=. python results/lossless/intbox21/scripts/box_local.py mri_dipy_s0,mri_nibabel_t1 \
        box:1x2x2:1 mean:1x3x3:4 stack:1x5x5:1      # kind:RZxRYxRX:classes
"""
import sys, time, json
import numpy as np
sys.path.insert(0, "scripts")
import datasets
from volpack import api
from volpack.volume_codec import localfit, floatfit, predictfit

ORIG = localfit.estimates
NONE = localfit.NONE
STATE = {"calls": 0, "weights": 0}

def box_design(v, box):
    rz, ry, rx = box
    nz, ny, nx = v.shape
    offs = floatfit.box_offsets(rz, ry, rx)
    P = np.pad(v.astype(np.float64), ((0, 0), (ry, ry), (rx, rx)), mode="edge")
    return offs, P

def box_estimates(v, box, classes=1):
    """Per-brick LS over the box (+ constant), weights quantized to 2^-12 (2 bytes each)."""
    rz, ry, rx = box
    nz, ny, nx = v.shape
    out = np.full(v.shape, NONE, np.int64)
    if nz <= rz or ny < 3 or nx < 3:
        return out, 0
    offs, P = box_design(v, box)
    k = len(offs) + 1
    def slab(z):
        cols = [P[z - dz, ry - dy + 1: ry - dy + ny, rx - dx + 1: rx - dx + nx].reshape(-1) for dz, dy, dx in offs]
        cols.append(np.ones((ny - 1) * (nx - 1)))
        return np.stack(cols, 1), v[z, 1:, 1:].reshape(-1).astype(np.float64)
    # gradient classes (as predictfit's) on the valid region
    def grad(z):
        W = v[z, 1:, :-1][:, :]; 
        vv = v.astype(np.int64)
        w_ = vv[z, 1:, 0:nx-1]; n_ = vv[z, 0:ny-1, 1:nx]; nw = vv[z, 0:ny-1, 0:nx-1]
        ne = np.concatenate([vv[z, 0:ny-1, 2:nx], vv[z, 0:ny-1, nx-1:nx]], 1)
        u = vv[z-1, 1:, 1:]; un = vv[z-1, 0:ny-1, 1:]; uw = vv[z-1, 1:, 0:nx-1]
        return (abs(w_-nw)+abs(n_-nw)+abs(n_-ne)+abs(u-un)+abs(u-uw)).reshape(-1)
    zs = range(max(rz, 1), nz)
    if classes > 1:
        g = np.concatenate([grad(z) for z in zs]); th = np.quantile(g, np.arange(1, classes) / classes)
    else:
        th = np.zeros(0)
    xtx = np.zeros((classes, k, k)); xty = np.zeros((classes, k)); cnt = np.zeros(classes, int)
    for z in zs:
        x, y = slab(z)
        c = np.searchsorted(th, grad(z), side="left") if classes > 1 else np.zeros(y.size, int)
        for cc in range(classes):
            s = c == cc
            xtx[cc] += x[s].T @ x[s]; xty[cc] += x[s].T @ y[s]; cnt[cc] += s.sum()
    ws = []
    for cc in range(classes):
        if cnt[cc] < 4 * k:
            w = np.linalg.lstsq(xtx.sum(0), xty.sum(0), rcond=None)[0]
        else:
            w = np.linalg.lstsq(xtx[cc] + 1e-6 * np.eye(k) * np.trace(xtx[cc]) / k, xty[cc], rcond=None)[0]
        ws.append(np.round(w[:-1] * 4096) / 4096)
        ws[-1] = np.append(ws[-1], np.round(w[-1] * 8) / 8)
    for z in zs:
        x, _ = slab(z)
        c = np.searchsorted(th, grad(z), side="left") if classes > 1 else np.zeros(x.shape[0], int)
        est = np.empty(x.shape[0])
        for cc in range(classes):
            s = c == cc
            est[s] = x[s] @ ws[cc]
        out[z, 1:, 1:] = np.floor(8 * est + 0.5).astype(np.int64).reshape(ny - 1, nx - 1)
    return out, classes * k * 2

def stack(v, box, loc, b):
    rz, ry, rx = box
    nz, ny, nx = v.shape
    offs, P = box_design(v, box)
    k = len(offs) + 2
    rows = []
    xtx = np.zeros((k, k)); xty = np.zeros(k)
    def slab(z):
        cols = [P[z - dz, ry - dy + 1: ry - dy + ny, rx - dx + 1: rx - dx + nx].reshape(-1) for dz, dy, dx in offs]
        cols.append(np.ones((ny - 1) * (nx - 1)))
        l = loc[z, 1:, 1:].reshape(-1)
        cols.append(l / 8.0)
        x = np.stack(cols, 1)
        return x, v[z, 1:, 1:].reshape(-1).astype(np.float64), l != NONE
    zs = range(max(rz, 2), nz)
    for z in zs:
        x, y, ok = slab(z)
        xtx += x[ok].T @ x[ok]; xty += x[ok].T @ y[ok]
    w = np.linalg.lstsq(xtx, xty, rcond=None)[0]
    w = np.round(w * 4096) / 4096
    STATE["weights"] += 2
    out = b.copy()
    for z in zs:
        x, y, ok = slab(z)
        e = np.floor(8 * (x @ w) + 0.5).astype(np.int64)
        cur = out[z, 1:, 1:].reshape(-1)
        cur[ok] = e[ok]
        out[z, 1:, 1:] = cur.reshape(ny - 1, nx - 1)
    return out


def make(kind, box=None, classes=1):
    def est(values, offsets):
        v = np.ascontiguousarray(values, dtype=np.int64)
        loc = ORIG(values, offsets)
        STATE["calls"] += 1
        if kind == "local":
            return loc
        b, nbytes = box_estimates(v, box, classes)
        STATE["weights"] += nbytes
        if kind == "box":
            return b
        if kind == "stack":  # LS over the box's neighbours, a constant and the local estimate
            return stack(v, box, loc, b)
        if kind == "mean":
            out = np.where(loc == NONE, b, np.where(b == NONE, loc, (loc + b + 1) >> 1))
            return out
        raise ValueError(kind)
    return est

def run(name, arr, kind, box=None, classes=1):
    localfit.estimates = make(kind, box, classes)
    STATE.update(calls=0, weights=0)
    t = time.process_time()
    n = len(api.compress_array(arr, effort="max", workers=1))
    localfit.estimates = ORIG
    return n, STATE["calls"], STATE["weights"], time.process_time() - t

if __name__ == "__main__":
    names = sys.argv[1].split(",")
    cands = [("local", None, 1)]
    for spec in sys.argv[2:]:
        kind, b, c = spec.split(":")
        cands.append((kind, tuple(int(t) for t in b.split("x")), int(c)))
    for name in names:
        arr, _, _ = datasets.load(name)
        raw = arr.nbytes
        base = None
        for kind, box, cl in cands:
            n, calls, wb, t = run(name, arr, kind, box, cl)
            tot = n + wb
            if base is None:
                base = tot
            print(json.dumps(dict(volume=name, cand=kind, box="x".join(map(str, box)) if box else "", classes=cl,
                  file_bytes=n, weight_bytes=wb, total=tot, ratio=round(raw / tot, 4),
                  saving_pct=round(100 * (base - tot) / base, 3), local_calls=calls, cpu_s=round(t, 1))), flush=True)
