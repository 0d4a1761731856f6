"""Oracle: least-squares fits of the 62 near neighbours per sub-block (no weights
charged) against one fit over the brick: what local adaptation of the predictor could
give at most (zeroth-order entropy of the rounded residual, interior voxels)."""
import sys
import numpy as np
from cells import cells, h, quantised
from volpack.volume_codec import lossy, bounded_longfit as lf


for name, rel, a, e in cells(sys.argv[1]):
    q = quantised(a, e)[0][1].astype(np.float64)
    offs = lf.class_offsets((8, 2), (8, 2), (8, 2))
    nz, ny, nx = q.shape
    z0, y0, x0 = 8, 8, 8
    A = np.stack([q[z0 - dz:nz - dz, y0 - dy:ny - 2 - dy, x0 - dx:nx - 2 - dx] for dz, dy, dx in offs], -1)
    t = q[z0:, y0:ny - 2, x0:nx - 2]
    Af = A.reshape(-1, len(offs)); tf = t.ravel()
    w = np.linalg.lstsq(Af, tf, rcond=None)[0]
    r = np.rint(tf - Af @ w)
    print(f"{name} {rel}: {len(offs)} steps, global fit {h(r)/r.size:.3f} b/v", end="")
    for bs in (32, 16):
        rl = np.empty_like(t)
        for zs in range(0, t.shape[0], bs):
            for ys in range(0, t.shape[1], bs):
                for xs in range(0, t.shape[2], bs):
                    sl = (slice(zs, zs + bs), slice(ys, ys + bs), slice(xs, xs + bs))
                    Ab = A[sl].reshape(-1, len(offs)); tb = t[sl].ravel()
                    wb = np.linalg.lstsq(Ab, tb, rcond=None)[0]
                    rl[sl] = np.rint(t[sl] - (Ab @ wb).reshape(t[sl].shape))
        print(f", blocks {bs}: {h(rl)/rl.size:.3f}", end="")
    print(flush=True)
