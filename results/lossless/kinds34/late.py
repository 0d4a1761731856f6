"""Volumes made after mode 6's code was final (none of them seen while writing it):
nearest-neighbour upsampled copies of corpus volumes other than the tuned-on AICHA atlas.

    PYTHONPATH=. python results/lossless/kinds34/late.py DIR

Writes DIR/NAME.npy and appends to DIR/late.txt; measure them with measure.py.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def up(a, factors):
    for ax, f in enumerate(factors):
        a = np.repeat(a, f, axis=ax)
    return a


def volumes():
    jhu = load("atlas_jhu_wm_2mm")[0]
    ct = load("ct_head")[0]
    bs = load("brainsmall")[0]
    km = load("labels_itk_kmeans")[0]
    return [
        ("jhu2mm_up2", "JHU WM atlas 2 mm upsampled 2x, cropped by one voxel at the start (odd phase), uint8",
         up(jhu, (2, 2, 2))[1:, 1:, 1:]),
        ("ct_up2z", "head CT slices 27:81 each repeated twice along z, int16", up(ct[27:81], (2, 1, 1))),
        ("brainsmall_x3", "brainsmall MRI repeated 3x along x (anisotropic voxels made cubic), uint8",
         up(bs, (1, 1, 3))),
        ("kmeans_up2", "ITK k-means labels upsampled 2x, uint8", up(km, (2, 2, 2))),
    ]  # fmt: skip


def main(d: Path) -> None:
    d.mkdir(parents=True, exist_ok=True)
    lines = []
    for name, text, a in volumes():
        a = np.ascontiguousarray(a)
        np.save(d / f"{name}.npy", a)
        lines.append(f"{name}\tlate\t{a.dtype} {'x'.join(map(str, a.shape))}\t{text}")
    (d / "late.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
