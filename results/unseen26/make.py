"""Synthetic fields of kinds the corpus lacks: a log-normal density (cosmology-like),
precipitation (mostly zeros, heavy tail), a shock (a discontinuity across a smooth field)."""
import numpy as np

r = np.random.default_rng(26)
n = 96
k = np.fft.fftfreq(n)
kz, ky, kx = np.meshgrid(k, k, k, indexing="ij")
kk = np.sqrt(kz**2 + ky**2 + kx**2)
kk[0, 0, 0] = 1
g = np.fft.ifftn(np.fft.fftn(r.normal(size=(n, n, n))) * kk ** -1.6).real
g = (g - g.mean()) / g.std()
np.save("lognormal.npy", np.exp(1.8 * g).astype(np.float32))           # density, 4 decades
p = np.maximum(g - 0.8, 0) ** 1.5 * 20
np.save("precip.npy", p.astype(np.float32))                               # ~80 % zeros
z, y, x = np.meshgrid(*(np.linspace(0, 1, n),) * 3, indexing="ij")
shock = np.where(x + 0.3 * np.sin(6 * y) * z < 0.55, 1.0, 4.0) * (1 + 0.2 * np.sin(5 * z + 3 * y)) + 0.05 * g
np.save("shock.npy", shock.astype(np.float32))
# Integer copies for the lossless check.
s = shock.astype(np.float32)
np.save("shock_u16.npy", np.rint((s - s.min()) / (s.max() - s.min()) * 4000).astype(np.uint16))
np.save("precip_u8.npy", np.rint(np.minimum(p.astype(np.float32), 255)).astype(np.uint8))
np.save("lognormal_i16.npy", np.rint(1.8 * g * 1000).astype(np.int16))  # log of the density x 1000
print("ok", (p == 0).mean())
