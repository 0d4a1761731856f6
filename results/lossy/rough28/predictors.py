"""Candidate predictors of the quantised field q, measured offline by the zeroth-order
entropy of their integer residuals (bits a voxel), and (ctx) their entropy conditioned
on 12 contexts of the mean magnitude of already-known residuals around the voxel (the
codec's context coders approach that; tables not counted).

python results/lossy/rough28/predictors.py FIELD.npy|name [REL ...]

- lorenzo: the 3-D Lorenzo predictor (previous-value in 3-D), causal;
- longfit: the codec's long least-squares causal predictor (bounded_longfit, the reach
  the encoder ranks first, its face classes), what wins on turb now;
- hier: two-sided hierarchical interpolation in SZ3's order (coarse to fine, per level
  an x, a y, then a z pass), each (level, pass) with its own 3-D weights fitted by least
  squares over the known points around the target (coefficients would be stored);
- hier wide (--wide): every known point within 3 (L1 <= 4) and every earlier target
  of the pass within 2, fitted the same way;
- hier+causal: the same plus the neighbours already decoded in the same pass (distance
  1 in the last passes), a blend of the two-sided and the causal predictor.
The hierarchical ones wrap around the faces (np.roll): exact for the periodic synthetic
field, a small favour to them elsewhere.
"""

import sys

import numpy as np

sys.path.insert(0, ".")
sys.path.insert(0, "results/lossy/rough28")

from bound import load  # noqa: E402

from volpack.volume_codec import bounded_longfit as lf  # noqa: E402


def h0(r):
    _, n = np.unique(r, return_counts=True)
    p = n / n.sum()
    return float(-(n * np.log2(p)).sum())


N_CTX = 12


def ctx_of(mags):
    """Context of a voxel from the mean magnitude of known residuals around it: its
    bit length (the codec's coders condition on such activity)."""
    m = np.mean(mags, 0)
    return np.minimum(np.floor(np.log2(1.0 + 4.0 * m)), N_CTX - 1).astype(np.int64)


def h_ctx(r, c):
    """Conditional empirical entropy of ``r`` given ``c`` (bits in all, tables not
    counted: what an adaptive coder in those contexts approaches)."""
    return sum(h0(r[c == k]) for k in np.unique(c))


def causal_ctx(r):
    """Context of each voxel of a causal (raster) residual: its decoded neighbours."""
    a = np.abs(np.pad(r, ((1, 0), (1, 0), (1, 1)))).astype(np.float64)
    nz, ny, nx = r.shape
    mags = [
        a[1:, 1:, 0:nx],
        a[1:, 0:ny, 1 : nx + 1],
        a[0:nz, 1:, 1 : nx + 1],
        a[1:, 0:ny, 2:],
        a[1:, 0:ny, 0:nx],
        a[0:nz, 0:ny, 1 : nx + 1],
    ]
    return ctx_of(mags)


def lorenzo(q):
    p = np.pad(q, ((1, 0), (1, 0), (1, 0)))
    pred = (
        p[1:, 1:, :-1]
        + p[1:, :-1, 1:]
        + p[:-1, 1:, 1:]
        - p[1:, :-1, :-1]
        - p[:-1, 1:, :-1]
        - p[:-1, :-1, 1:]
        + p[:-1, :-1, :-1]
    )
    return q - pred


# Offsets (dz, dy, dx) in units of the level's stride, of known points per pass.
TWO_SIDED = {
    "x": [(0, 0, d) for d in (-3, -1, 1, 3)]
    + [(a, b, d) for d in (-1, 1) for a, b in ((2, 0), (-2, 0), (0, 2), (0, -2))],
    "y": [(0, d, 0) for d in (-3, -1, 1, 3)]
    + [(0, d, e) for d in (-1, 1) for e in (-1, 1)]
    + [(a, d, 0) for d in (-1, 1) for a in (-2, 2)],
    "z": [(d, 0, 0) for d in (-3, -1, 1, 3)]
    + [(d, a, b) for d in (-1, 1) for a, b in ((0, 1), (0, -1), (1, 0), (-1, 0))]
    + [(d, a, b) for d in (-1, 1) for a in (-1, 1) for b in (-1, 1)],
}
# ... and the targets of the same pass decoded before (raster order within the pass).
CAUSAL = {
    "x": [(0, 0, -2), (0, -2, -1), (0, -2, 1), (-2, 0, -1), (-2, 0, 1)],
    "y": [(0, 0, -1), (0, 0, -2), (0, -2, -1), (0, -2, 1), (-2, -1, 0), (-2, 1, 0)],
    "z": [(0, 0, -1), (0, -1, 0), (0, -1, -1), (0, -1, 1), (0, 0, -2), (0, -2, 0), (-2, 0, 0)],
}


PARITY = {"x": (0, 0, 1), "y": (0, 1, None), "z": (1, None, None)}


def _known(p, d):
    """Is the point at offset ``d`` from a target of pass ``p`` known before the pass?"""
    par = [(t + o) % 2 if t is not None else None for t, o in zip(PARITY[p], d)]
    if p == "x":
        return par == [0, 0, 0]
    if p == "y":
        return par[0] == 0 and par[1] == 0
    return par[0] == 0


def _in_pass(p, d):
    """... or a target of the same pass decoded before it (raster order)."""
    par = [(t + o) % 2 if t is not None else None for t, o in zip(PARITY[p], d)]
    mine = [t if t is not None else q for t, q in zip(PARITY[p], par)]
    return par == mine and d < (0, 0, 0)


def wide_offsets(p, two=3, causal=2):
    """Every known point within ``two`` (box, L1 <= two + 1) and every earlier target of
    the pass within ``causal`` (box) of the target."""
    r = range(-two, two + 1)
    out = [
        d
        for d in ((a, b, c) for a in r for b in r for c in r)
        if _known(p, d) and sum(map(abs, d)) <= two + 1
    ]
    r = range(-causal, causal + 1)
    out += [d for d in ((a, b, c) for a in r for b in r for c in r) if _in_pass(p, d)]
    return out


def targets(pass_, shape):
    """Index slices of the pass's targets in the level's grid."""
    e, o, a = slice(0, None, 2), slice(1, None, 2), slice(None)
    return {"x": (e, e, o), "y": (e, o, a), "z": (o, a, a)}[pass_]


def hier(q, causal=False, top=32, wide=False):
    """Residual bits of the hierarchical LS interpolation (wrapping at the faces)."""
    q = q.astype(np.float64)
    bits, count, cbits = 0.0, 0, 0.0
    res = np.zeros_like(q)
    coarse = q[::top, ::top, ::top]
    bits += coarse.size * 32  # the coarsest grid raw
    cbits += coarse.size * 32
    count += coarse.size
    s = top // 2
    per = []
    while s >= 1:
        g = q[::s, ::s, ::s]
        for p in ("x", "y", "z"):
            sl = targets(p, g.shape)
            offs = wide_offsets(p) if wide else TWO_SIDED[p] + (CAUSAL[p] if causal else [])
            t = g[sl].reshape(-1)
            k = max(1, t.size // 200000)  # fitted on a subsample of large passes

            def feature(d, g=g, sl=sl):
                return np.roll(g, tuple(-v for v in d), (0, 1, 2))[sl].reshape(-1)

            a = np.stack([feature(d)[::k] for d in offs], 1)
            w, *_ = np.linalg.lstsq(a, t[::k], rcond=None)
            pred = np.zeros_like(t)
            for wj, d in zip(w, offs):
                pred += wj * feature(d)
            r = t - np.rint(pred)
            b = h0(r) + 32 * len(offs)  # weights stored as 32-bit values
            bits += b
            rg = res[::s, ::s, ::s]
            rg[sl] = r.reshape(rg[sl].shape)
            near = [d for d in offs if max(map(abs, d)) <= 1][:8]
            mags = [
                np.abs(np.roll(rg, tuple(-v for v in d), (0, 1, 2))[sl]).reshape(-1) for d in near
            ]
            cbits += h_ctx(r, ctx_of(mags)) + 32 * len(offs)
            count += t.size
            per.append((s, p, t.size, b / t.size))
        s //= 2
    assert count == q.size, (count, q.size)
    per.append(("ctx", cbits / q.size))
    return bits / q.size, per


def main():
    x = load(sys.argv[1])
    flags = [a for a in sys.argv[2:] if a.startswith("--")]
    rels = [float(r) for r in sys.argv[2:] if not r.startswith("--")] or [1e-2, 1e-3, 1e-4, 1e-5]
    xf = x.astype(np.float64)
    lo, hi = xf.min(), xf.max()
    n = min(x.shape)
    top = 1 << int(np.log2(n // 4))
    for rel in rels:
        q = np.rint((xf - lo) / (2 * rel * (hi - lo))).astype(np.int64)
        out = {"lorenzo": h0(lorenzo(q)) / q.size}
        for reach in lf.tried_reaches(q):
            r, _, _ = lf.residuals(q, reach, prune=True)
            out[f"longfit{reach}"] = h0(r) / q.size
            out[f"longfit{reach} ctx"] = h_ctx(r.reshape(-1), causal_ctx(r).reshape(-1)) / q.size
        if all(m % (2 * top) == 0 for m in x.shape):
            out["hier"], per = hier(q, False, top)
            out["hier ctx"] = per[-1][1]
            out["hier+causal"], per2 = hier(q, True, top)
            out["hier+causal ctx"] = per2[-1][1]
            if "--wide" in flags:
                out["hier wide"], _ = hier(q, True, top, wide=True)
        print(f"rel {rel:g}: " + ", ".join(f"{k} {v:.3f}" for k, v in out.items()), flush=True)
        if "hier" in out:
            print(
                "   last passes (s=1) hier:",
                ", ".join(f"{p} {b:.3f}" for s, p, _, b in per[:-1] if s == 1),
                "| +causal:",
                ", ".join(f"{p} {b:.3f}" for s, p, _, b in per2[:-1] if s == 1),
            )


if __name__ == "__main__":
    main()
