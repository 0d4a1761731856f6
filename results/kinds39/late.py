"""Three more volumes made after the code was final (named in LATE.md before any run),
run once: the tuned kinds stored otherwise.

    PYTHONPATH=. python results/kinds39/late.py DIR

- phase_u12: MRI phase as a scanner stores it (Siemens: uint16 holding 0..4095 for
  -pi..pi): a new head and B0 field (seed 3990), wrapped, random phase outside; lossless.
- dti_6first: a DTI tensor field with its 6 components first, (6, z, y, x) (seed 3991).
- cells_u32: an instance segmentation whose ids are large and sparse (uint32 hashes of
  the cell index below 2^31, as some pipelines write them; seed 3992).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make  # noqa: E402

LATE = ("phase_u12", "dti_6first", "cells_u32")


def phase_u12(rng):
    shape = (80, 144, 144)
    z, y, x = make.grid(shape, -1.0, 1.0)
    head = (z / 0.8) ** 2 + (y / 0.92) ** 2 + (x / 0.8) ** 2 < 1
    dz, dy, dx = z + 0.3, y - 0.5, x + 0.1
    r2 = dz**2 + dy**2 + dx**2 + 0.02
    dip = (3 * dz**2 / r2 - 1) / r2**1.5 * 0.01
    b0 = (
        -3 * z
        + 2 * y * x
        + 4 * y**2
        - 2 * z * x
        + dip * 30
        + 0.5 * make.gauss_field(rng, shape, -5.0)
    )
    ph = 2.0 * b0 + rng.normal(scale=0.04, size=shape)
    ph = np.where(head, ph, rng.uniform(-np.pi, np.pi, size=shape))
    w = (ph + np.pi) % (2 * np.pi)
    return np.minimum(np.floor(w / (2 * np.pi) * 4096), 4095).astype(np.uint16)


def dti_6first(rng):
    return np.ascontiguousarray(np.moveaxis(make.dti_f32(rng), -1, 0))


def cells_u32(rng):
    lab = make.cells_u16(rng).astype(np.uint64)
    ids = (np.arange(int(lab.max()) + 1, dtype=np.uint64) * np.uint64(2654435761)) % np.uint64(
        2**31
    )
    ids[0] = 0
    return ids[lab].astype(np.uint32)


if __name__ == "__main__":
    d = Path(sys.argv[1])
    for i, name in enumerate(LATE):
        a = globals()[name](np.random.default_rng(3990 + i))
        np.save(d / f"{name}.npy", a)
        print(name, a.shape, a.dtype, flush=True)
