"""Volumes for session 37's fill-value and small-volume trial (helper rend37; issue 22).

    PYTHONPATH=. python results/render/rend37/make.py   # writes results/render/rend37/vols/*

Tuning: ``smooth_fill.npy`` (float32 48x56x64, a seeded smooth field, values about
0..30, with -9999 in the voxels where a second seeded smooth field is below its 20th
percentile: a fill region shaped like land on a climate grid).
Held out (HELDOUT.md): ``jhu_crop.nii.gz`` (a seeded 48x64x64 crop of the JHU 189-region
label atlas, uint8), ``camt_fill.npy`` (CAM temperature, float32 14x64x128, with 1e20 in
the voxels where a seeded smooth field is below its 15th percentile: a fill ABOVE the
data, as CF files write it).
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import datasets  # noqa: E402

from volpack.api import write_volume  # noqa: E402
from volpack.volume import Volume  # noqa: E402

OUT = Path(__file__).resolve().parent / "vols"


def smooth(shape, seed, k=6):
    """A smooth random field: k Gaussian bumps of random centre, width and sign."""
    rng = np.random.default_rng(seed)
    g = np.meshgrid(*[np.linspace(0, 1, n) for n in shape], indexing="ij")
    f = np.zeros(shape, np.float64)
    for _ in range(k):
        c = rng.random(3)
        w = 0.12 + 0.25 * rng.random()
        f += rng.uniform(-1, 1) * np.exp(-sum((gi - ci) ** 2 for gi, ci in zip(g, c)) / (2 * w * w))
    return f


def smooth_fill():
    f = smooth((48, 56, 64), 3701)
    f = (f - f.min()) / (f.max() - f.min()) * 30.0
    land = smooth((48, 56, 64), 3702, k=4)
    f[land < np.percentile(land, 20)] = -9999.0
    return f.astype(np.float32)


def jhu_crop():
    vol, sp, _ = datasets.load("atlas_jhu189")
    rng = np.random.default_rng(3703)
    shape = (48, 64, 64)
    for _ in range(1000):
        c = [int(rng.integers(0, n - s + 1)) for n, s in zip(vol.shape, shape)]
        sub = vol[c[0] : c[0] + shape[0], c[1] : c[1] + shape[1], c[2] : c[2] + shape[2]]
        if np.mean(sub > 0) >= 0.25 and len(np.unique(sub)) > 2:
            return np.ascontiguousarray(sub), sp
    raise RuntimeError("no crop found")


def camt_fill():
    vol, sp, _ = datasets.load("cam_t14")
    vol = vol.astype(np.float32).copy()
    m = smooth(vol.shape, 3704, k=4)
    vol[m < np.percentile(m, 15)] = 1e20
    return vol


def main():
    OUT.mkdir(exist_ok=True)
    np.save(OUT / "smooth_fill.npy", smooth_fill())
    if "--heldout" in sys.argv:
        sub, sp = jhu_crop()
        write_volume(Volume(sub, spacing=sp), str(OUT / "jhu_crop.nii.gz"), force=True)
        np.save(OUT / "camt_fill.npy", camt_fill())
    for p in sorted(OUT.iterdir()):
        print(p.name)


if __name__ == "__main__":
    main()
