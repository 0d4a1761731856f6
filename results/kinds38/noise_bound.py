"""How far any coder can go on the trial's misses: entropy of each volume's noise with the
noise-free part given for free (a lower bound on any lossless coder's bytes), and for the
two lossy misses the Shannon lower bound h(X) - log2(2E) of their random part from the
spectrum it was made with (Kolmogorov-Szego, as results/lossy/rough28/bound.py).

    PYTHONPATH=. python results/kinds38/noise_bound.py DATA_DIR > results/kinds38/noise_bound.txt

DATA_DIR is make.py's output; volpack's bytes are read from trial_base.jsonl (and
trial_fillvalue.jsonl for letkf_t), the peers' from the same lines.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage, stats

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make  # noqa: E402

D = Path(sys.argv[1])


def cells(path):
    out = {}
    for line in open(HERE / path):
        c = json.loads(line)
        out[c["name"], c["rel"]] = c["json"]
    return out


BASE = cells("trial_base.jsonl")
FILL = cells("trial_fillvalue.jsonl")


def gauss_h(sigma):
    """Entropy (bits) of rint(s + sigma Z) for a real s, averaged over the fraction of s:
    for sigma >= 1 it is the differential entropy to within 1e-3 bits."""
    return 0.5 * np.log2(2 * np.pi * np.e * sigma**2)


def disc_h(p):
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


def report(name, bound_bytes, rel=None, j=None):
    j = j or BASE[name, rel]
    vb = j["file_nbytes"]
    peers = [
        q
        for q in j["peers"]
        if (
            q.get("lossless")
            if rel is None
            else (q["name"] in ("sz3", "sperr") and q["bound_held"])
        )
    ]
    b = min(peers, key=lambda q: q["file_nbytes"])
    n = int(np.prod(j["shape"]))
    print(f"{name}{'' if rel is None else ' at ' + rel}: bound {bound_bytes:,.0f} B ({8 * bound_bytes / n:.3f} bits/voxel); "
          f"volpack {vb:,} B = {vb / bound_bytes:.3f}x the bound; best peer {b['name']} {b['file_nbytes']:,} B = "
          f"{b['file_nbytes'] / bound_bytes:.3f}x; 1.1x that peer needs {b['file_nbytes'] / 1.1 / bound_bytes:.3f}x the bound")  # fmt: skip


# lobster_u8: rint(s + u) with u uniform on 0..14 and s real: given s, log2(15) bits exactly
a = np.load(D / "lobster_u8.npy")
report("lobster_u8", a.size * np.log2(15) / 8)

# frog_u8: rint(hypot(v + n1, n2)), n Gaussian of sigma 5, v the blurred tissue image
rng = np.random.default_rng(3800 + list(make.MAKERS).index("frog_u8"))
lab, _, _ = make.load("frog_labels")
zi = np.rint(np.linspace(0, lab.shape[0] - 1, 44)).astype(int)
lab = lab[zi, ::2, ::2]
table = rng.uniform(30, 220, size=int(lab.max()) + 1)
table[0] = 6.0
v = ndimage.gaussian_filter(table[lab], (0.3, 0.9, 0.9))
grid = np.arange(0, 230, 0.05)
edges = np.arange(-0.5, 300.5, 1.0)
hs = np.array(
    [disc_h(np.diff(stats.rice.cdf(np.clip(edges, 0, None), g / 5.0, scale=5.0))) for g in grid]
)
report("frog_u8", np.interp(v, grid, hs).sum() / 8)

# tooth_u16: _ct_object's noise sigma * sqrt(v / 1000 + 0.2) on the blurred object v
cap = {}
orig = make._ct_object


def capture(rng, shape, parts, air=40.0, sigma=28.0, blur=0.8, bits=12):
    w = np.full(shape, air)
    for m, val in parts:
        w[m] = val
    cap["v"], cap["sigma"] = ndimage.gaussian_filter(w, blur), sigma
    return orig(rng, shape, parts, air, sigma, blur, bits)


make._ct_object = capture
make.tooth_u16(np.random.default_rng(3800 + list(make.MAKERS).index("tooth_u16")))
s = cap["sigma"] * np.sqrt(cap["v"] / 1000.0 + 0.2)
report("tooth_u16", gauss_h(s).sum() / 8)

# exafel_i16: rint(30 K + 3 Z), K Poisson(lambda): the combs 30 apart do not overlap, so
# H = H(Poisson(lambda)) + H(rint(3 Z)) on live pixels; gaps, dead and hot pixels are fixed
parts = {}
make._exafel(np.random.default_rng(3800 + list(make.MAKERS).index("exafel_i16")), parts=parts)
lams, live = parts["lam"], parts["live"]
lg = np.exp(np.linspace(np.log(1e-3), np.log(2000), 400))
hp = np.array([disc_h(stats.poisson.pmf(np.arange(int(L + 12 * np.sqrt(L) + 30)), L)) for L in lg])
hn = disc_h(np.diff(stats.norm.cdf(np.arange(-40.5, 41.5), scale=3.0)))
h = np.interp(np.log(lams[:, live]), np.log(lg), hp) + hn
report("exafel_i16", h.sum() / 8)
print(
    f"  (exafel_i16: H(rint(3 Z)) = {hn:.3f} bits, mean H(K) on live pixels {h.mean() - hn:.3f} bits; live {live.mean():.3%})"
)


# the lossy misses: Shannon lower bound of the random part, from its generating spectrum
def innovation_var(power):
    p = power.reshape(-1)[1:]
    p = p[p > 0]
    return float(np.exp(np.mean(np.log(p))))


def spectrum(shape, slope, stretch=(1.0, 1.0, 1.0)):
    ks = [np.fft.fftfreq(m) * s for m, s in zip(shape, stretch)]
    kk = np.sqrt(sum(k**2 for k in np.meshgrid(*ks, indexing="ij")))
    kk.flat[0] = 1.0
    h2 = kk**slope
    return h2 / h2.reshape(-1)[1:].mean()  # unit variance, as gauss_field's


# reconn_j: J = sheets - 0.002 laplacian(g), g of slope -4; np.gradient twice is the
# stride-2 second difference, transfer -sin^2(2 pi f) / h^2 along each axis
shape = (96, 96, 128)
fs = np.meshgrid(*(np.fft.fftfreq(m) for m in shape), indexing="ij")
lap = sum(np.sin(2 * np.pi * f) ** 2 * (m - 1) ** 2 for f, m in zip(fs, shape))
pj = 0.002**2 * spectrum(shape, -4.0) * lap**2
vj = innovation_var(pj)
a = np.load(D / "reconn_j.npy").astype(np.float64)
for rel in ("1e-2", "1e-3", "1e-4"):
    e = float(rel) * (a.max() - a.min())
    slb = max(0.5 * np.log2(2 * np.pi * np.e * vj) - np.log2(2 * e), 0.0)
    print(f"  reconn_j at {rel}: noise innovation sigma {np.sqrt(vj):.4g} (bound E {e:.4g}); "
          f"lower bound {slb:.3f} bits/voxel")  # fmt: skip
    if slb > 0:
        report("reconn_j", slb * a.size / 8, rel)

# letkf_t: trend + 2 K x g (slope -3.5, stretched 3x along z); fill voxels free
shape = (98, 128, 160)
vt = innovation_var(4.0 * spectrum(shape, -3.5, (3, 1, 1)))
a = np.load(D / "letkf_t.npy").astype(np.float64)
ok = a > -1e29
for rel in ("1e-2", "1e-3", "1e-4"):
    e = float(rel) * (a[ok].max() - a[ok].min())
    slb = max(0.5 * np.log2(2 * np.pi * np.e * vt) - np.log2(2 * e), 0.0)
    print(f"  letkf_t at {rel} (fill declared): anomaly innovation sigma {np.sqrt(vt):.4g} K (E {e:.4g} K); "
          f"lower bound {slb:.3f} bits/valid voxel")  # fmt: skip
    if slb > 0:
        report("letkf_t", slb * ok.sum() / 8, rel, FILL["letkf_t", rel])
