"""Is the long fit's residual still linearly predictable from the causal residuals? A
least-squares fit of r on 10 of them (interior voxels) and the variance it leaves.

    python results/lossy/lossy19/resid_acorr.py tgv_pressure:1e-5,tas_monthly:1e-5
"""
import sys

import numpy as np
from cells import cells, quantised

from volpack.volume_codec import bounded_longfit as lf

OFFS = [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (1, 1, 0), (1, 0, 1),
        (0, 0, 2), (0, 2, 0), (2, 0, 0)]  # fmt: skip
for name, rel, a, e in cells(sys.argv[1]):
    q = quantised(a, e)[0][1]
    reach = lf.rank_reaches(np.ascontiguousarray(q, np.int64))[0]
    r = lf.residuals(q, reach, int(np.iinfo(q.dtype).max))[0].astype(np.float64)
    nz, ny, nx = r.shape
    t = r[2:, 2:-2, 2:-2].ravel()
    A = np.stack([r[2 - dz:nz - dz, 2 - dy:ny - 2 - dy, 2 - dx:nx - 2 - dx].ravel()
                  for dz, dy, dx in OFFS], 1)  # fmt: skip
    corr = [round(float(np.corrcoef(t, A[:, k])[0, 1]), 3) for k in range(len(OFFS))]
    left = t - A @ np.linalg.lstsq(A, t, rcond=None)[0]
    ratio = left.var() / t.var()
    print(f"{name} {rel} reach {reach}: correlations {corr}; variance left {ratio:.4f} "
          f"(~{-0.5 * np.log2(ratio):.4f} bits a voxel)")
