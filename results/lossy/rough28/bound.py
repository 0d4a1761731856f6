"""The entropy rate of the quantised field q (and of the field) under a Gaussian model (Kolmogorov-Szego:
the innovation variance of the best causal linear predictor of infinite reach is the
geometric mean of the power spectrum), against the bits a voxel volpack spends.

python results/lossy/rough28/bound.py FIELD.npy|name
For a Gaussian field (the synthetic turbulence) this is its true entropy rate; for any
other field with the same spectrum the true rate is lower (the Gaussian has the most
entropy), so the figures bound only the Gaussian ones. From the field's own spectrum,
h(X) - log2(2E) a voxel is the Shannon lower bound of any coder that keeps every
voxel within E (the most entropy an error in [-E, E] can have is log2(2E)): a 32-bit
field's ratio is at most 32 over it. Note: the spectrum is the periodogram of the whole (periodic or not) volume; for a
non-periodic field the faces add power at high k, so the figure is a rough guide.
"""

import sys

import numpy as np

sys.path.insert(0, "scripts")


def load(name):
    if name.endswith(".npy"):
        return np.load(name)
    from datasets import load as dl

    return dl(name)[0]


def ks_bits(q):
    f = np.fft.fftn(q - q.mean())
    p = (np.abs(f) ** 2) / q.size
    p = p.reshape(-1)[1:]  # without the mean
    # a periodogram value is its expectation times an exponential variable, whose log
    # averages -Euler's gamma: the geometric mean is corrected by e^gamma
    var = np.exp(np.mean(np.log(np.maximum(p, 1e-12))) + np.euler_gamma)
    return var, 0.5 * np.log2(2 * np.pi * np.e * var)


if __name__ == "__main__":
    x = load(sys.argv[1]).astype(np.float64)  # (float32 fields: ratio against 32 bits)
    lo, hi = x.min(), x.max()
    var_x, _ = ks_bits(x)
    for rel in (1e-2, 1e-3, 1e-4, 1e-5):
        step = 2 * rel * (hi - lo)
        q = np.rint((x - lo) / step)
        var, hq = ks_bits(q)
        slb = 0.5 * np.log2(2 * np.pi * np.e * var_x / step**2)  # h(X) - log2(2E)
        most = f"ratio at most {32 / slb:.3f}" if slb > 0 else "no bound"
        print(
            f"rel {rel:g}: q innovation var {var:.4g} bins^2, entropy rate of q {hq:.3f} "
            f"bits/voxel; Shannon lower bound {slb:.3f} bits/voxel ({most})"
        )
