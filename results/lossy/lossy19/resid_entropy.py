"""Where the long fit's residual bits go: zeroth-order entropy per voxel inside and near
the faces, and the entropy given a local activity context (static, an estimate)."""
import sys
import numpy as np
from cells import cells, h, quantised
from volpack.volume_codec import lossy, bounded_longfit as lf


def golomb_bits(r, ctx, nctx):
    # bucket = bit length of zigzag, coded in context; low bits raw
    z = np.where(r >= 0, 2 * r, -2 * r - 1)
    nb = np.where(z > 0, np.floor(np.log2(np.maximum(z, 1))) + 1, 0).astype(np.int64)
    raw = np.maximum(nb - 1, 0).sum()
    tot = 0.0
    for c in range(nctx):
        s = nb[ctx == c]
        if s.size:
            tot += h(s) + 0.5 * len(np.unique(s)) * np.log2(max(s.size, 2))
    return tot + raw

for name, rel, a, e in cells(sys.argv[1]):
    q = quantised(a, e)[0][1]
    reach = lf.rank_reaches(np.ascontiguousarray(q, np.int64))[0]
    r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max))
    nz, ny, nx = r.shape
    inner = np.zeros(r.shape, bool)
    kz, ky, kx = reach
    inner[kz:, ky:ny - 2, kx:nx - 2] = True
    print(f"{name} {rel} reach {reach} H0 {h(r)/8:.0f} B; inner {inner.mean():.2f} of voxels "
          f"{h(r[inner])/inner.sum():.3f} b/v, faces {h(r[~inner])/(~inner).sum():.3f} b/v")
    ar = np.abs(r).astype(np.float64)
    pad = np.pad(ar, 2, mode="constant")
    P = lambda dz, dy, dx: pad[2 - dz:2 - dz + nz, 2 - dy:2 - dy + ny, 2 - dx:2 - dx + nx]
    for label, nbrs in [("W,N,U", [(0,0,1),(0,1,0),(1,0,0)]),
                        ("W,N,U,NW,NE,WW,NN", [(0,0,1),(0,1,0),(1,0,0),(0,1,1),(0,1,-1),(0,0,2),(0,2,0)]),
                        ("12 near", [(0,0,1),(0,1,0),(1,0,0),(0,1,1),(0,1,-1),(0,0,2),(0,2,0),(1,1,0),(1,0,1),(1,-1,0),(1,0,-1),(2,0,0)])]:
        act = sum(P(*o) for o in nbrs) / len(nbrs)
        for nctx in (1, 8, 16):
            if nctx == 1:
                ctx = np.zeros(r.shape, np.int64)
            else:
                edges = np.quantile(act, np.linspace(0, 1, nctx + 1)[1:-1])
                ctx = np.searchsorted(edges, act)
            print(f"   ctx {label:22s} {nctx:2d}: {golomb_bits(r, ctx, nctx)/8:.0f} B")
