"""How many bits a voxel a larger least-squares predictor would save on the quantised
voxels of the bounded codec at tight bounds (issue 21, lossy17): an estimate, no coder.

The quantised voxels ``q = rint((x - lo) / 2E)`` are what the `q` path codes losslessly,
and predicting ``q`` from its causal neighbours is SZ3-style closed-loop prediction (the
decoded values are ``lo + 2E q``). For each field and bound: the fitted linear predictor
over the causal neighbours of a set (fitted by least squares on the brick's interior), the
residual ``q - rint(pred)`` and its entropy conditioned on a local activity context
(the mean |residual| of five causal neighbours, 32 log buckets; interior voxels 8 from
the faces, where every set's neighbours exist), in bits a voxel; beside
it the bits a voxel volpack's whole stream spends now. Sets: predictfit's 16 neighbours,
floatfit's 23, all causal neighbours within radius 2 (62), and those with the
next 6 back along each axis (80; bounded_longfit's set at reach 8).

python scripts/lossy17_predictor_entropy.py --datasets tgv_vorticity,tgv_u --rels 1e-4,1e-5
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import datasets  # noqa: E402

from volpack.volume_codec.bounded_longfit import long_offsets, near_offsets  # noqa: E402

P16 = (
    (0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (1, 0, 1), (1, 1, 0), (1, 1, 1),
    (0, 0, 2), (0, 2, 0), (2, 0, 0), (1, 0, -1), (1, -1, 0), (1, 1, -1), (1, -1, 1), (1, -1, -1),
)  # fmt: skip
P23 = P16 + ((0, 1, 2), (0, 2, 1), (0, 2, -1), (2, 1, 0), (2, 0, 1), (1, 2, 0), (1, 0, 2))


def design(q: np.ndarray, offs, m: int):
    nz, ny, nx = q.shape
    core = q[m:, m:ny - m, m:nx - m].astype(np.float64)
    cols = [q[m - dz:nz - dz, m - dy:ny - m - dy, m - dx:nx - m - dx].astype(np.float64).ravel()
            for dz, dy, dx in offs]
    return np.stack(cols, axis=1), core.ravel(), core.shape


def cond_entropy(r: np.ndarray, shape) -> float:
    """Entropy of r given a bucket of the mean |r| at W, N, U, NW, NE (causal), bits."""
    a = np.abs(r).reshape(shape).astype(np.float64)
    act = np.zeros_like(a)
    act[1:, 1:, 1:-1] = (a[1:, 1:, :-2] + a[1:, :-1, 1:-1] + a[:-1, 1:, 1:-1]
                         + a[1:, :-1, :-2] + a[1:, :-1, 2:]) / 5
    ctx = np.minimum((np.log2(1 + act) * 2).astype(np.int64), 31).ravel()
    total = 0.0
    for c in np.unique(ctx):
        v = r[ctx == c]
        _, n = np.unique(v, return_counts=True)
        p = n / n.sum()
        # ideal adaptive coder cost ~ empirical entropy + alphabet learning cost
        total += -(n * np.log2(p)).sum() + 0.5 * len(n) * np.log2(max(len(v), 2))
    return total / r.size


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--datasets", default="tgv_vorticity,tgv_u,tgv_pressure,mri_piesno_noise")
    ap.add_argument("--rels", default="1e-3,1e-4,1e-5")
    ap.add_argument("--volpack", action="store_true", help="also code with volpack (bits/voxel)")
    a = ap.parse_args()
    sets = {"p16": P16, "p23": P23, "r2": near_offsets(), "r2+axes8": long_offsets(8)}
    print("field,rel,volpack_bpv,lorenzo," + ",".join(sets))
    for name in a.datasets.split(","):
        x, _, _ = datasets.load(name)
        x = x.astype(np.float32)
        lo, hi = float(x.min()), float(x.max())
        for rel in (float(s) for s in a.rels.split(",")):
            e = rel * (hi - lo)
            q = np.rint((x.astype(np.float64) - lo) / (2 * e))
            row = [name, f"{rel:g}"]
            if a.volpack:
                from volpack import api

                row.append(f"{8 * len(api.compress_array(x, max_error=e)) / x.size:.3f}")
            else:
                row.append("")
            m = 8  # the same interior voxels for every set
            _, ys, shape = design(q, P16, m)
            nz, ny, nx = q.shape

            def sh(dz, dy, dx):
                return q[m - dz:nz - dz, m - dy:ny - m - dy, m - dx:nx - m - dx].ravel()

            # 3-D Lorenzo: W + N + U - NW - UW - UN + UNW
            lor = (sh(0, 0, 1) + sh(0, 1, 0) + sh(1, 0, 0) - sh(0, 1, 1) - sh(1, 0, 1)
                   - sh(1, 1, 0) + sh(1, 1, 1))
            row.append(f"{cond_entropy(ys - lor, shape):.3f}")
            for offs in sets.values():
                xs, ys, shape = design(q, offs, m)
                w, *_ = np.linalg.lstsq(xs, ys, rcond=None)
                r = ys - np.rint(xs @ w)
                row.append(f"{cond_entropy(r, shape):.3f}")
            print(",".join(row), flush=True)


if __name__ == "__main__":
    main()
