"""What bounds the held-out volumes below 1.1x (session 23): residual entropies of three
causal predictors, the bits/voxel of volpack and JPEG-XL e3 from lossless.csv, and the
bit planes of the float field.

    PYTHONPATH=.:scripts python results/lossless/heldout23/diagnose.py
"""

import csv
from pathlib import Path

import numpy as np

import datasets

HERE = Path(__file__).resolve().parent
ROWS = list(csv.DictReader(open(HERE / "lossless.csv")))


def entropy(r):
    _, c = np.unique(r, return_counts=True)
    p = c / c.sum()
    return float(-(p * np.log2(p)).sum())


def bpv(name, method, bits):
    (r,) = [r for r in ROWS if r["dataset"] == name and r["method"] == method and r["workers"] == "1"]
    return bits / float(r["ratio"])


for name in ("mri_emri_dicom", "mri_afni_epi", "mri_parrec_phantom", "mni152_wm"):
    v = datasets.load(name)[0]
    bits = 8 * v.dtype.itemsize
    a = v.astype(np.int64)
    x, w, n, nw = a[:, 1:, 1:], a[:, 1:, :-1], a[:, :-1, 1:], a[:, :-1, :-1]
    med = np.where(nw >= np.maximum(w, n), np.minimum(w, n),
                   np.where(nw <= np.minimum(w, n), np.maximum(w, n), w + n - nw))
    lor = (a[1:, 1:, 1:] - a[1:, 1:, :-1] - a[1:, :-1, 1:] - a[:-1, 1:, 1:]
           + a[1:, :-1, :-1] + a[:-1, 1:, :-1] + a[:-1, :-1, 1:] - a[:-1, :-1, :-1])
    print(f"{name} {v.shape} {v.dtype}: H(MED in-plane) {entropy(x - med):.3f}, "
          f"H(3-D Lorenzo) {entropy(lor):.3f}, H(slice difference) {entropy(a[1:] - a[:-1]):.3f}; "
          f"volpack {bpv(name, 'volpack', bits):.3f}, volpack-max {bpv(name, 'volpack-max', bits):.3f}, "
          f"JPEG-XL e3 {bpv(name, 'jpegxl-e3', bits):.3f} bits/voxel; zeros {np.mean(v == 0):.3f}")

for name in ("seam_ps", "sst_monthly"):
    a = datasets.load(name)[0]
    u = a.view(np.uint32)
    planes = [float(((u >> b) & 1).mean()) for b in range(16)]
    print(f"{name}: {len(np.unique(a))} distinct of {a.size}; bits 0-15 set in "
          f"{100 * min(planes):.1f}-{100 * max(planes):.1f} % of voxels; "
          f"x100 off an integer by at most {np.abs(a * 100 - np.rint(a * 100)).max():.2g}")
