"""A lower bound on the bits a voxel of any coder keeping every voxel of the synthetic
shock (results/unseen26/make.py) within E, from how it was made: the shock is a
deterministic field plus 0.05 g, g white Gaussian noise filtered by |k|^-1.6 and
normalised by its std. Knowing the deterministic part can only help a coder, so
R >= h(0.05 g) - log2(2E) a voxel, and h of a linear filter of white noise is the
noise's entropy plus the mean log2 of the filter's gains (the mean mode aside).

python results/lossy/rough28/shock_bound.py   (rebuilds g with the same seed)
"""
import json
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]

r = np.random.default_rng(26)
n = 96
k = np.fft.fftfreq(n)
kz, ky, kx = np.meshgrid(k, k, k, indexing="ij")
kk = np.sqrt(kz**2 + ky**2 + kx**2)
kk[0, 0, 0] = 1
g = np.fft.ifftn(np.fft.fftn(r.normal(size=(n, n, n))) * kk ** -1.6).real
gain = kk ** -1.6 * 0.05 / g.std()  # of the white noise (variance 1) into 0.05 g
h = 0.5 * np.log2(2 * np.pi * np.e) + np.mean(np.log2(gain.reshape(-1)[1:]))
print(f"h(0.05 g) = {h:.3f} bits a voxel (differential)")
for e in ("1e-2", "1e-3", "1e-4", "1e-5"):
    d = json.loads((ROOT / f"results/unseen26/lossy/shock-{e}.json").read_text())
    c = d["compress"]
    p = {q["name"]: q for q in d["peers"]}
    best = max(p["sz3"]["ratio"], p["sperr"]["ratio"])
    big_e = c["codec"]["max_error"]
    slb = h - np.log2(2 * big_e)
    most = f"{32 / slb:.2f} ({32 / slb / best:.3f}x best peer)" if slb > 0 else "no bound"
    print(f"{e}: bound {slb:.3f} bits a voxel, ratio at most {most}; volpack {c['ratio']:.2f} "
          f"({c['ratio'] / best:.3f}x best peer {best:.2f})")
