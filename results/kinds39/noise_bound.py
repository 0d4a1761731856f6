"""How far any coder can go on the trial's lossless misses: the entropy of each volume's
noise with the noise-free part given for free (a lower bound on any lossless coder's
bytes; kinds38's noise_bound.py, these volumes' noise models from make.py).

    PYTHONPATH=. python results/kinds39/noise_bound.py DATA_DIR [RUN.jsonl] > results/kinds39/noise_bound.txt

DATA_DIR is make.py's output; volpack's and the peers' bytes are read from RUN.jsonl
(default trial_base.jsonl).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from scipy import stats

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make  # noqa: E402

D = Path(sys.argv[1])
RUN = HERE / (sys.argv[2] if len(sys.argv) > 2 else "trial_base.jsonl")
CELLS = {}
for line in open(RUN):
    c = json.loads(line)
    CELLS[c["name"], c["rel"]] = c["json"]


def gauss_h(sigma):
    """Entropy (bits) of rint(s + sigma Z), s real (to 1e-3 bits for sigma >= 1)."""
    return 0.5 * np.log2(2 * np.pi * np.e * sigma**2)


def disc_h(p):
    p = p[p > 0]
    return float(-(p * np.log2(p)).sum())


def report(name, bound_bytes):
    j = CELLS.get((name, None))
    if j is None:
        return
    vb = j["file_nbytes"]
    b = min((q for q in j["peers"] if q.get("lossless")), key=lambda q: q["file_nbytes"])
    n = int(np.prod(j["shape"]))
    print(f"{name}: bound {bound_bytes:,.0f} B ({8 * bound_bytes / n:.3f} bits/voxel); "
          f"volpack {vb:,} B = {vb / bound_bytes:.3f}x the bound; best peer {b['name']} {b['file_nbytes']:,} B = "
          f"{b['file_nbytes'] / bound_bytes:.3f}x; 1.1x that peer needs {b['file_nbytes'] / 1.1 / bound_bytes:.3f}x the bound")  # fmt: skip


def seed(name):
    return np.random.default_rng(3900 + list(make.MAKERS).index(name))


# fibsem_u8: white Gaussian noise of sigma 7 added last (no clipping in the volume: 15..210)
a = np.load(D / "fibsem_u8.npy")
report("fibsem_u8", a.size * gauss_h(7.0) / 8)

# rock_u16 / rock_u8: white Gaussian noise added last (sigma 1100 / 9)
for name, s in (("rock_u16", 1100.0), ("rock_u8", 9.0)):
    if (D / f"{name}.npy").exists():
        a = np.load(D / f"{name}.npy", mmap_mode="r")
        report(name, a.size * gauss_h(s) / 8)

# cbct_i16: sigma 35 inside the cylindrical field of view (r < 0.49); -1000 outside, free
a = np.load(D / "cbct_i16.npy", mmap_mode="r")
z, y, x = make.grid(a.shape)
fov = np.hypot(y - 0.5, x - 0.5) < 0.49
report("cbct_i16", fov.sum() * gauss_h(35.0) / 8)


# lightsheet_u16: rint(100 + 2.17 K + 1.6 Z), K Poisson(lambda): lambda captured from make
class Capture:
    def __init__(self, rng):
        self.rng, self.lam = rng, None

    def __getattr__(self, k):
        return getattr(self.rng, k)

    def poisson(self, lam, *a, **kw):
        self.lam = np.asarray(lam)
        return self.rng.poisson(lam, *a, **kw)


cap = Capture(seed("lightsheet_u16"))
make.lightsheet_u16(cap)
lam = cap.lam
lg = np.exp(np.linspace(np.log(0.05), np.log(lam.max() * 1.01), 200))
edges = np.arange(-40.5, 2.17 * lg.max() + 12 * np.sqrt(lg.max()) * 2.17 + 60, 1.0)


def h_adu(L):
    k = np.arange(int(L + 12 * np.sqrt(L) + 20))
    pk = stats.poisson.pmf(k, L)
    p = sum(
        w * np.diff(stats.norm.cdf(edges, loc=2.17 * kk, scale=1.6))
        for kk, w in zip(k, pk)
        if w > 1e-12
    )
    return disc_h(p)


hs = np.array([h_adu(L) for L in lg])
report("lightsheet_u16", np.interp(np.log(lam), np.log(lg), hs).sum() / 8)


# phase_f32 (lossy): inside the head, phase noise of sigma 0.05 rad on a smooth field (its
# Shannon lower bound at max error E: h(N(0, 0.05^2)) - log2(2E), the smooth field free);
# outside it, uniform phase on [-pi, pi): log2(2 pi / 2E) bits, exactly what uniform bins
# of 2E need. The wraps inside are given for free too.
LOSSY = {}
for line in open(RUN):
    c = json.loads(line)
    if c["rel"]:
        LOSSY[c["name"], c["rel"]] = c["json"]
if ("phase_f32", "1e-2") in LOSSY:
    a = np.load(D / "phase_f32.npy", mmap_mode="r")
    z, y, x = make.grid(a.shape, -1.0, 1.0)
    f = float(((z / 0.85) ** 2 + (y / 0.9) ** 2 + (x / 0.75) ** 2 < 1).mean())
    for rel in ("1e-2", "1e-3", "1e-4"):
        j = LOSSY["phase_f32", rel]
        e = float(rel) * 2 * np.pi
        hin = max(gauss_h(0.05) - np.log2(2 * e), 0.0)
        hout = np.log2(2 * np.pi / (2 * e))
        bound = (f * hin + (1 - f) * hout) * a.size / 8
        sz = [q for q in j["peers"] if q["name"] == "sz3"][0]["file_nbytes"]
        vb = j["file_nbytes"]
        print(f"phase_f32 at {rel}: head {f:.1%} of the voxels; bound {bound:,.0f} B ({hin:.2f} bits inside, {hout:.2f} outside); "
              f"volpack {vb:,} B = {vb / bound:.3f}x the bound; SZ3 {sz:,} B = {sz / bound:.3f}x; 1.1x SZ3 needs {sz / 1.1 / bound:.3f}x the bound")  # fmt: skip

# phase_u12 (late.py, lossless): inside the head phase noise of 0.04 rad = 26.08 codes,
# outside uniform on the 4096 codes (12 bits exactly); the wraps given for free
if ("phase_u12", None) in CELLS:
    a = np.load(D / "phase_u12.npy", mmap_mode="r")
    z, y, x = make.grid(a.shape, -1.0, 1.0)
    head = (z / 0.8) ** 2 + (y / 0.92) ** 2 + (x / 0.8) ** 2 < 1
    n_in = int(head.sum())
    print(f"  (phase_u12: head {n_in / a.size:.1%} of the voxels)")
    report("phase_u12", (n_in * gauss_h(0.04 * 4096 / (2 * np.pi)) + (a.size - n_in) * 12.0) / 8)
