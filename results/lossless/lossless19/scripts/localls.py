import numpy as np, numba
from volpack.volume_codec.predictfit import FIT_OFFSETS
OFF = np.array(FIT_OFFSETS, np.int64)

@numba.njit(cache=False)
def local_ls(v, R, RU, lam, minn):
    nz, ny, nx = v.shape
    nf = OFF.shape[0] + 1
    out = np.full(v.size, -1, np.int64)
    f = np.empty(nf)
    for z in range(2, nz):
        for y in range(2, ny - 1):
            for x in range(2, nx - 1):
                A = np.zeros((nf, nf)); b = np.zeros(nf); n = 0
                for zz in (z - 1, z):
                    rr = R if zz == z else RU
                    for yy in range(max(y - rr, 2), min(y + (0 if zz == z else rr), ny - 2) + 1):
                        for xx in range(max(x - rr, 2), min(x + rr, nx - 2) + 1):
                            if zz == z and yy == y and xx >= x:
                                break
                            for k in range(nf - 1):
                                f[k] = v[zz - OFF[k, 0], yy - OFF[k, 1], xx - OFF[k, 2]]
                            f[nf - 1] = 1.0
                            t = v[zz, yy, xx]
                            for a in range(nf):
                                b[a] += f[a] * t
                                for c in range(a, nf):
                                    A[a, c] += f[a] * f[c]
                            n += 1
                if n < minn:
                    continue
                tr = 0.0
                for a in range(nf):
                    for c in range(a):
                        A[a, c] = A[c, a]
                    tr += A[a, a]
                for a in range(nf):
                    A[a, a] += lam * tr / nf + 1e-9
                w = np.linalg.solve(A, b)
                for k in range(nf - 1):
                    f[k] = v[z - OFF[k, 0], y - OFF[k, 1], x - OFF[k, 2]]
                f[nf - 1] = 1.0
                p = 0.0
                for a in range(nf):
                    p += w[a] * f[a]
                out[(z * ny + y) * nx + x] = int(np.round(8 * p))
    return out
