"""Three float32 fields of kinds volpack was never tuned on (seeded).

The lead's script (/work/wt/shared28/make_lossy.py) as it was, with --seed and --slope
(rough28): `python make_lossy.py` makes the three fields as before; `python
make_lossy.py --seed S --slope P --name N` makes only the turbulence-like field, 128^3
with power spectrum k^P, as N.npy.
"""

import argparse

import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("--seed", type=int, default=28)
ap.add_argument("--slope", type=float, default=None)
ap.add_argument("--name", default="turb")
args = ap.parse_args()
rng = np.random.default_rng(args.seed)


def grf(n, slope):
    k = np.fft.fftfreq(n) * n
    kz, ky, kx = np.meshgrid(k, k, np.fft.rfftfreq(n) * n, indexing="ij")
    kk = np.sqrt(kz**2 + ky**2 + kx**2)
    kk[0, 0, 0] = 1
    amp = kk ** (slope / 2)
    amp[0, 0, 0] = 0
    spec = amp * (rng.standard_normal(kk.shape) + 1j * rng.standard_normal(kk.shape))
    f = np.fft.irfftn(spec, s=(n, n, n), axes=(0, 1, 2))
    return f / f.std()


n = 128
if args.slope is not None:
    f = grf(n, args.slope).astype(np.float32)
    np.save(args.name + ".npy", f)
    print(args.name, f.shape, f.min(), f.max())
    raise SystemExit
turb = grf(n, -11 / 3).astype(np.float32)  # Kolmogorov velocity component
np.save("turb.npy", turb)

m = 96
z, y, x = np.meshgrid(*(np.linspace(-1, 1, m),) * 3, indexing="ij")
orb = np.zeros((m, m, m))
for _ in range(24):  # Gaussian-enveloped waves (orbital-like)
    c = rng.uniform(-0.6, 0.6, 3)
    kv = rng.normal(0, 9, 3)
    w = rng.uniform(0.15, 0.4)
    r2 = (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2
    orb += (
        rng.normal()
        * np.exp(-r2 / (2 * w * w))
        * np.cos(kv[0] * z + kv[1] * y + kv[2] * x + rng.uniform(0, 6.3))
    )
np.save("orbital.npy", orb.astype(np.float32))

h = 0.1 * grf(m, -4)[0] / 3  # interface height, multi-mode
zz = np.linspace(-1, 1, m)[:, None, None]
d = zz - h[None]
mix = 2 + np.tanh(d / 0.05) + 0.3 * np.exp(-((d / 0.15) ** 2)) * grf(m, -11 / 3)
np.save("mixing.npy", mix.astype(np.float32))
for k in ("turb", "orbital", "mixing"):
    a = np.load(k + ".npy")
    print(k, a.shape, a.min(), a.max())
