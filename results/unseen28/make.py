"""Volumes volpack was never tuned on, written as .npy into the current folder.

Lossless: real volumes of the corpus stored as users store them elsewhere (12-bit CT in the
high bits, an offset unsigned copy, int32, integers held in float32 and float64, an 8-bit
MRI doubled or rescaled to 16 bits, another axis order, a 4-voxel slab, added noise,
big-endian). Lossy: three seeded float32 fields of kinds the corpus lacks: a Kolmogorov
turbulence component (power spectrum k^-11/3, no dissipation range), an orbital-like sum
of Gaussian-enveloped waves, and a mixing layer (a perturbed tanh interface with
turbulence inside it). Run from the repository root's scripts/ data cache:
``python results/unseen28/make.py OUTDIR``."""

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "scripts"))
from datasets import load  # noqa: E402


def variants() -> dict:
    """The lossless copies: real scans of the corpus stored as other programs store them."""
    ct, mri, bs, dip = (load(n)[0] for n in ("ct_head", "mri_ch2", "brainsmall", "mri_dipy_s0"))
    rng = np.random.default_rng(5)
    return {
        "ct_x16": (ct.astype(np.int32) * 16).astype(np.int16),
        "ct_u16off": (ct.astype(np.int32) + 31000).astype(np.uint16),
        "ct_i32": ct.astype(np.int32),
        "ct_f32int": ct.astype(np.float32),
        "ct_f64int": ct.astype(np.float64),
        "mri_even": (mri.astype(np.uint16) * 2).astype(np.uint16),
        "mri_T": np.ascontiguousarray(mri.transpose(2, 0, 1)),
        "mri_thin": np.ascontiguousarray(mri[:, 100:104, :]),
        "bs_noise": np.clip(bs.astype(np.int16) + rng.integers(-2, 3, bs.shape), 0, 255).astype(
            np.uint8
        ),
        "dip_be": dip.astype(">u2"),
        "mri_scaled": np.round(mri.astype(np.float64) * 257.3).astype(np.uint16),
    }


def grf(rng, n: int, slope: float) -> np.ndarray:
    """A periodic Gaussian random field of n^3 voxels with power spectrum k^slope, unit
    variance."""
    k = np.fft.fftfreq(n) * n
    kz, ky, kx = np.meshgrid(k, k, np.fft.rfftfreq(n) * n, indexing="ij")
    kk = np.sqrt(kz**2 + ky**2 + kx**2)
    kk[0, 0, 0] = 1
    amp = kk ** (slope / 2)
    amp[0, 0, 0] = 0
    spec = amp * (rng.standard_normal(kk.shape) + 1j * rng.standard_normal(kk.shape))
    f = np.fft.irfftn(spec, s=(n, n, n), axes=(0, 1, 2))
    return f / f.std()


def fields(rng) -> dict:
    """The three float32 fields, drawn from ``rng`` in this order (it fixes the fields)."""
    turb = grf(rng, 128, -11 / 3)
    m = 96
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, m),) * 3, indexing="ij")
    orb = np.zeros((m, m, m))
    for _ in range(24):
        c = rng.uniform(-0.6, 0.6, 3)
        kv = rng.normal(0, 9, 3)
        w = rng.uniform(0.15, 0.4)
        r2 = (z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2
        a = rng.normal()  # drawn before the phase
        phase = kv[0] * z + kv[1] * y + kv[2] * x + rng.uniform(0, 6.3)
        orb += a * np.exp(-r2 / (2 * w * w)) * np.cos(phase)
    h = 0.1 * grf(rng, m, -4)[0] / 3
    d = np.linspace(-1, 1, m)[:, None, None] - h[None]
    mix = 2 + np.tanh(d / 0.05) + 0.3 * np.exp(-((d / 0.15) ** 2)) * grf(rng, m, -11 / 3)
    return {k: v.astype(np.float32) for k, v in (("turb", turb), ("orbital", orb), ("mixing", mix))}


if __name__ == "__main__":
    out = Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    out.mkdir(parents=True, exist_ok=True)
    made = {**variants(), **fields(np.random.default_rng(28))}
    for name, v in made.items():
        np.save(out / f"{name}.npy", v)
    print("wrote", len(made), "volumes to", out)
