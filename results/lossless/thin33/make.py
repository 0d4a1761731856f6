"""Thin stacks for the thin-volume work (session 33, thin33), seeded.

    PYTHONPATH=. python results/lossless/thin33/make.py DIR

Tuned on: the three of session 32's trial (results/cli/user32/make.py, same recipes and
seed order for the microscopy stack). Held out: slices and slabs of other scans of
scripts/datasets.py and a second synthetic stack (another seed and shape).
Writes DIR/NAME.npy and DIR/volumes.txt (name, set, description).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def blobs(shape, n, radius, rng):
    """Fluorescent nuclei: Gaussian blobs at random centres (as user32's make.py)."""
    img = np.zeros(shape, np.float64)
    pts = tuple(rng.integers(0, s, n) for s in shape)
    img[pts] = 1.0
    return ndimage.gaussian_filter(img, radius) * (2 * np.pi * radius**2) ** 1.5


def micro(shape, n, seed):
    rng = np.random.default_rng(seed)
    return rng.poisson(blobs(shape, n, 3.0, rng) * 800 + 100).astype(np.uint16)


def volumes():
    """(name, set, description, array) of every volume (array None: user32's stack)."""
    names = ("ct_head", "mri_ch2", "mri_mni152", "mri_itk_t1", "mri_dipy_s0", "brainsmall")
    names += ("mri_ch2better",)
    scan = {n: load(n)[0] for n in names}
    ct = scan["ct_head"]
    thick = np.round(ndimage.zoom(ct.astype(np.float32), (8 / ct.shape[0], 1, 1), order=1))
    mid = {n: a[a.shape[0] // 2][None].copy() for n, a in scan.items()}
    return [
        ("ct_slice1", "tuned", "head CT, middle slice, (1, 256, 256) int16", mid["ct_head"]),
        ("ct_8thick", "tuned", "head CT resampled to 8 thick slices, int16", thick.astype(np.int16)),
        # (user32's make.py drew it from a generator shared with its other volumes: read
        # from DIR/../user32/ when there, else seeded 32 alone)
        ("micro_12x1024", "tuned", "widefield-like 12x1024x1024 uint16 (user32's)", None),
        ("ch2_slice1", "held", "Colin27 T1 MRI, middle axial slice, (1, 217, 181) uint8", mid["mri_ch2"]),
        ("mni_slab8", "held", "MNI152 T1, 8 middle slices, uint8", scan["mri_mni152"][90:98].copy()),
        ("itk_slab3", "held", "ITK T1 MRI, 3 middle slices, int16", scan["mri_itk_t1"][30:33].copy()),
        ("dipy_s0_slab5", "held", "dipy b0 MRI, 5 middle slices, uint16", scan["mri_dipy_s0"][2:7].copy()),
        ("ct_slab4", "held", "head CT, 4 native slices near the skull base (30:34), int16", ct[30:34].copy()),
        ("ct_slice2", "held", "head CT, 2 native slices at 80:82, int16", ct[80:82].copy()),
        ("brainsmall_slab6", "held", "brainsmall MRI (.den), 6 slices at 40:46, uint8", scan["brainsmall"][40:46].copy()),
        ("ch2better_slice1", "held", "Colin27 0.5 mm T1, middle slice, (1, 370, 301) uint8", mid["mri_ch2better"]),
        ("micro_6x768", "held", "widefield-like 6x768x1024 uint16, seed 7, 700 nuclei", micro((6, 768, 1024), 700, 7)),
    ]  # fmt: skip


def main(d: Path) -> None:
    d.mkdir(parents=True, exist_ok=True)
    lines = []
    for name, kind, text, a in volumes():
        if a is None:
            src = d.parent / "user32" / f"{name}.npy"
            a = np.load(src) if src.exists() else micro((12, 1024, 1024), 1500, 32)
        np.save(d / f"{name}.npy", a)
        lines.append(f"{name}\t{kind}\t{a.dtype} {'x'.join(map(str, a.shape))}\t{text}")
    (d / "volumes.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
