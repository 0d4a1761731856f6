"""The Tucker decoder's product of a core and three factor matrices, in a fixed order.

numpy's ``tensordot`` hands the sums to BLAS, whose order of additions (and use of fused
multiply-add) varies between libraries and CPUs. Here every sum runs over increasing
index from 0.0, in double precision, without contraction (:func:`volpack._jit.kernel`):
the same stored integers give the same voxels everywhere IEEE-754 doubles do.
"""

from __future__ import annotations

import numpy as np

from .._jit import kernel


@kernel
def expand_kernel(core, u0, u1, u2, mean, t0, t1, out):
    """``out = mean + core x1 u0 x2 u1 x3 u2``, each sum in increasing index order."""
    r0, r1, r2 = core.shape
    n0, n1, n2 = u0.shape[0], u1.shape[0], u2.shape[0]
    t0[:] = 0.0
    for j in range(r0):
        for a in range(n0):
            w = u0[a, j]
            for k in range(r1):
                for m in range(r2):
                    t0[a, k, m] += w * core[j, k, m]
    t1[:] = 0.0
    for a in range(n0):
        for k in range(r1):
            for b in range(n1):
                w = u1[b, k]
                for m in range(r2):
                    t1[a, b, m] += w * t0[a, k, m]
    for a in range(n0):
        for b in range(n1):
            for c in range(n2):
                s = 0.0
                for m in range(r2):
                    s += u2[c, m] * t1[a, b, m]
                out[a, b, c] = s + mean


def expand(core: np.ndarray, factors, mean: float, shape) -> np.ndarray:
    """The brick (float64) of the dequantised ``core``, ``factors`` and ``mean``."""
    n0, n1, n2 = shape
    r0, r1, r2 = core.shape
    out = np.empty(shape, np.float64)
    t0 = np.empty((n0, r1, r2), np.float64)
    t1 = np.empty((n0, n1, r2), np.float64)
    expand_kernel(
        np.ascontiguousarray(core, np.float64),
        *(np.ascontiguousarray(u, np.float64) for u in factors),
        np.float64(mean),
        t0,
        t1,
        out,
    )
    return out
