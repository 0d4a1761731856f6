"""Float fields of kinds no lossy trial had (session 35, helper lossy35); seeded.

Run: PYTHONPATH=. python results/lossy/lossy35/make.py DIR   (writes DIR/<name>.npy)
Held out (named before any run, see heldout.md): point_sources, stratified, synth_f64,
storm_u_nan.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

from datasets import load  # noqa: E402

N = 96
HELD_OUT = ("point_sources", "stratified", "synth_f64", "storm_u_nan")


def grid(n=N):
    return np.meshgrid(*(np.linspace(0.0, 1.0, n),) * 3, indexing="ij")


def smooth_noise(rng, n, slope):
    k = np.fft.fftfreq(n)
    kz, ky, kx = np.meshgrid(k, k, k, indexing="ij")
    kk = np.sqrt(kz**2 + ky**2 + kx**2)
    kk[0, 0, 0] = 1.0
    g = np.fft.ifftn(np.fft.fftn(rng.normal(size=(n, n, n))) * kk ** (slope / 2)).real
    return (g - g.mean()) / g.std()


def seismic(rng):
    """A Ricker wavelet on a spherical front in a 3-layer medium (velocity per layer),
    travel time by the vertical layers' slowness along depth, geometric spreading 1/r."""
    z, y, x = grid()
    v = np.where(z < 0.3, 1.0, np.where(z < 0.6 + 0.05 * np.sin(6 * x), 1.6, 2.3))
    # travel time approximated by straight rays with the mean slowness above the point
    slow = np.cumsum(1.0 / v, axis=0) / np.arange(1, N + 1)[:, None, None]
    r = np.sqrt((z - 0.05) ** 2 + (y - 0.5) ** 2 + (x - 0.45) ** 2) + 1e-3
    t = r * slow
    f0 = 18.0
    a = (np.pi * f0 * (t - 0.55)) ** 2
    w = (1 - 2 * a) * np.exp(-a) / (0.1 + r)
    return w.astype(np.float32)


def trilinear_up(rng):
    """A coarse 13^3 random field interpolated trilinearly up to 97^3 (8x)."""
    c = rng.normal(size=(13, 13, 13))
    t = np.linspace(0, 12, 97)
    i0 = np.minimum(t.astype(int), 11)
    f = t - i0
    out = c
    for ax in range(3):
        a = np.take(out, i0, axis=ax)
        b = np.take(out, i0 + 1, axis=ax)
        sh = [1, 1, 1]
        sh[ax] = -1
        out = a * (1 - f.reshape(sh)) + b * f.reshape(sh)
    return (20 + 5 * out).astype(np.float32)


def piecewise(rng):
    """Material values: 5 regions with smooth (spherical and wavy) boundaries."""
    z, y, x = grid()
    m = np.full(z.shape, 1.0)
    m[z > 0.55 + 0.08 * np.sin(5 * x) * np.cos(4 * y)] = 2.7
    m[(z - 0.3) ** 2 + (y - 0.4) ** 2 + (x - 0.6) ** 2 < 0.04] = 7.85
    m[(z - 0.7) ** 2 + (y - 0.7) ** 2 + (x - 0.3) ** 2 < 0.02] = 0.92
    m[(x > 0.8) & (y < 0.3)] = 1.225e-3
    return m.astype(np.float32)


def cic(rng):
    """Cloud-in-cell deposit of 200k particles in 40 clumps (plus a thin background) on 96^3."""
    n = N
    centres = rng.uniform(0.1, 0.9, size=(40, 3))
    sig = rng.uniform(0.005, 0.03, size=40)
    k = rng.integers(0, 40, size=180_000)
    p = centres[k] + rng.normal(size=(k.size, 3)) * sig[k, None]
    p = np.concatenate([p, rng.uniform(0, 1, size=(20_000, 3))])
    p = np.clip(p, 0, 0.999999) * (n - 1)
    i = np.floor(p).astype(int)
    f = p - i
    rho = np.zeros((n, n, n))
    for dz in (0, 1):
        for dy in (0, 1):
            for dx in (0, 1):
                w = (f[:, 0] if dz else 1 - f[:, 0]) * (f[:, 1] if dy else 1 - f[:, 1])
                w = w * (f[:, 2] if dx else 1 - f[:, 2])
                np.add.at(rho, (i[:, 0] + dz, i[:, 1] + dy, i[:, 2] + dx), w)
    return rho.astype(np.float32)


def stratified(rng):
    """Smooth across (y, x), sharp layers along z: tanh steps of width ~1 voxel."""
    z, y, x = grid()
    base = 0.3 * np.sin(3 * x + 1) * np.cos(2 * y)
    f = np.zeros_like(z)
    for j, zc in enumerate(np.linspace(0.08, 0.92, 9)):
        f += (0.5 + 0.3 * j % 2) * np.tanh((z - zc - 0.02 * np.sin(4 * y + j)) * N)
    return (f + base + 0.05 * z).astype(np.float32)


def point_sources(rng):
    """A potential of 12 point charges, sum q / r, clipped at 1/r = 1/(0.5 voxel)."""
    z, y, x = grid()
    f = np.zeros_like(z)
    for _ in range(12):
        c = rng.uniform(0.1, 0.9, 3)
        q = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2)
        r = np.sqrt((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2)
        f += q / np.maximum(r, 0.5 / N)
    return f.astype(np.float32)


def quantised(rng):
    """int16 values times a scale: a smooth field stored as int16 * 0.0125 (as a HDF5
    scale_factor would give), 96^3."""
    g = smooth_noise(rng, N, -3.5)
    q = np.rint(g * 4000).astype(np.int16)
    return (q.astype(np.float32) * np.float32(0.0125)).astype(np.float32)


def real_f64(rng):
    """The Taylor-Green pressure (real float32 DNS) cast to float64."""
    return np.asarray(load("tgv_pressure")[0], dtype=np.float64)


def synth_f64(rng):
    """A synthetic float64 field: smooth random field (slope -4) plus Gaussians, 80^3."""
    g = smooth_noise(rng, 80, -4.0)
    z, y, x = grid(80)
    for _ in range(5):
        c = rng.uniform(0.2, 0.8, 3)
        g += 3 * np.exp(-((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) / 0.005)
    return g.astype(np.float64)


def sst_nan(rng):
    """sea-surface temperature with its land (stored as -1.8 where it never changes over
    the 12 months... here: every voxel at exactly -1.8) set to NaN."""
    a = np.array(load("sst_monthly")[0], dtype=np.float32)
    a[a == np.float32(-1.8)] = np.nan
    return a


def storm_u_nan(rng):
    """storm_u with its fill (-9999, 19 %) set to NaN."""
    a = np.array(load("storm_u")[0], dtype=np.float32)
    a[a == -9999] = np.nan
    return a


def offset(rng):
    """1e4 + O(1): a smooth field of range ~4 on a constant offset, float32."""
    return (1e4 + smooth_noise(rng, N, -4.0)).astype(np.float32)


MAKERS = {
    "seismic": seismic,
    "trilinear_up": trilinear_up,
    "piecewise": piecewise,
    "cic_density": cic,
    "stratified": stratified,
    "point_sources": point_sources,
    "quantised_i16": quantised,
    "real_f64": real_f64,
    "synth_f64": synth_f64,
    "sst_nan": sst_nan,
    "storm_u_nan": storm_u_nan,
    "offset_1e4": offset,
}


def main(out: str) -> None:
    d = Path(out)
    d.mkdir(parents=True, exist_ok=True)
    for i, (name, make) in enumerate(MAKERS.items()):
        a = make(np.random.default_rng(3500 + i))
        np.save(d / f"{name}.npy", a)
        fin = a[np.isfinite(a)]
        print(name, a.shape, a.dtype, f"{fin.min():.6g}..{fin.max():.6g}",
              f"nan {np.isnan(a).mean():.3f}", f"zero {(a == 0).mean():.3f}")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1])
