"""Seeded crops for session 36's small-volume trial (helper rend36; issue 22).

    PYTHONPATH=. python results/render/rend36/make.py   # writes results/render/rend36/vols/*.nii.gz

Each crop keeps its dataset's dtype and spacing (NIfTI, so ``bench_render_peers.py
--volumes F.nii.gz`` reads the spacing). The crop's corner is drawn by a seeded generator
among the corners whose crop holds at least a quarter of voxels above the volume's median,
so a crop is tissue, not air. Tuning: ``ct_crop`` (CT head, int16), ``mri_crop`` (MRI ch2,
uint8). Held out (HELDOUT.md): ``liver_crop`` (a label map, uint8).
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
CROPS = {  # name: (dataset, crop shape (z, y, x), seed)
    "ct_crop": ("ct_head", (48, 80, 80), 3601),
    "mri_crop": ("mri_ch2", (64, 64, 64), 3602),
    "liver_crop": ("liver_labels", (40, 72, 72), 3603),
}


def crop(vol, shape, seed):
    rng = np.random.default_rng(seed)
    med = np.median(vol)
    for _ in range(1000):
        c = [int(rng.integers(0, n - s + 1)) for n, s in zip(vol.shape, shape)]
        sub = vol[c[0] : c[0] + shape[0], c[1] : c[1] + shape[1], c[2] : c[2] + shape[2]]
        if np.mean(sub > med) >= 0.25 and sub.max() > sub.min():
            return np.ascontiguousarray(sub), c
    raise RuntimeError("no crop found")


def main():
    OUT.mkdir(exist_ok=True)
    for name, (ds, shape, seed) in CROPS.items():
        vol, sp, _ = datasets.load(ds)
        sub, corner = crop(vol, shape, seed)
        write_volume(Volume(sub, spacing=sp), str(OUT / f"{name}.nii.gz"), force=True)
        print(name, ds, sub.shape, sub.dtype, sp, "corner", corner, "range", sub.min(), sub.max())


if __name__ == "__main__":
    main()
