"""Scratch (session 21): in-sample RMS residual of one least-squares fit per brick over the
blend's 16 neighbours and over boxes of causal neighbours (each with a constant), on the
same voxels (slices from 2, rows and columns 2 in from the edges and the box's margin).

    PYTHONPATH=. python results/lossless/intbox21/scripts/box_rms.py mri_dipy_s0 mri_nibabel_t1
"""
import sys
import numpy as np
sys.path.insert(0, "scripts")
import datasets
from volpack.volume_codec import floatfit, predictfit

BOXES = ((1, 2, 2), (1, 3, 3), (1, 5, 5), (1, 7, 7), (2, 3, 3))
for name in sys.argv[1:]:
    v = datasets.load(name)[0].astype(np.float64)
    nz, ny, nx = v.shape
    m = 7  # common margin: every set sees the same targets
    zs = slice(2, nz)
    y = v[zs, m:ny - m, m:nx - m].reshape(-1)
    def design(offs):
        cols = [v[2 - dz:nz - dz, m - dy:ny - m - dy, m - dx:nx - m - dx].reshape(-1) for dz, dy, dx in offs]
        return np.stack(cols + [np.ones(y.size)], 1)
    def rms(offs):
        x = design(offs)
        w = np.linalg.lstsq(x, y, rcond=None)[0]
        return float(np.sqrt(np.mean((y - x @ w) ** 2))), x.shape[1]
    r16, k16 = rms(predictfit.FIT_OFFSETS)
    print(f"{name}: {y.size} targets; 16 neighbours: RMS {r16:.3f} ({k16} weights)")
    for b in BOXES:
        r, k = rms(floatfit.box_offsets(*b))
        print(f"  box {b[0]}x{b[1]}x{b[2]}: RMS {r:.3f} ({k} weights), {100 * (r16 - r) / r16:+.2f} %")
