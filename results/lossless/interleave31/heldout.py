"""Held-out 4-D series for interleave31, made after the rule was fixed (corpus.txt):

- us_cine_grey: pydicom-data's ultrasound clip (color3d_jpeg_baseline.dcm, 120 frames
  of 480x640 RGB), frames 40-79 cut to the central 240x320, its luma as (t, 1, y, x)
  uint8 (a 2-D+t series);
- us_cine_rgb: the same cut with its 3 colour planes as z: (t, 3, y, x) uint8;
- sst_series: sst_monthly (NCL's monthly sea surface temperature, 12 months) as a
  (12, 1, 91, 181) float32 series;
- perfusion: a CT perfusion-like series: 24 time steps of ct_head's slices 40-71
  (int16 HU), a gamma-variate bolus of up to 80 HU added where the tissue is 20-80 HU,
  arriving later with depth, and noise of sigma 6 HU per time step (seed 31);
- dwi: a diffusion-like series: 33 directions of ch2bet's slices 60-79 (uint8 -> uint16
  x8), attenuated by exp(-b D(dir)) with D per voxel from its intensity and a random
  fibre direction, Rician-like noise (seed 31).

Each is run like measure.py: PYTHONPATH=. python results/lossless/interleave31/heldout.py OUT_STEM
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(Path(__file__).parent))

import measure  # noqa: E402
from datasets import load  # noqa: E402


def us_cine() -> np.ndarray:
    import data_store
    import pydicom

    path = os.path.join(os.path.dirname(data_store.__file__), "data", "color3d_jpeg_baseline.dcm")
    return pydicom.dcmread(path).pixel_array  # (t, y, x, 3), as pydicom converts it


def series() -> list[tuple[str, str, np.ndarray]]:
    rng = np.random.default_rng(31)
    clip = us_cine()[40:80, 120:360, 160:480]
    grey = np.rint(clip @ np.array([0.299, 0.587, 0.114])).clip(0, 255).astype(np.uint8)
    out = [
        ("us_cine_grey", "held out", np.ascontiguousarray(grey[:, None])),
        ("us_cine_rgb", "held out", np.ascontiguousarray(clip.transpose(0, 3, 1, 2))),
        ("sst_series", "held out", np.ascontiguousarray(load("sst_monthly")[0][:, None])),
    ]
    ct = load("ct_head")[0][40:72].astype(np.float64)
    t = np.arange(24, dtype=np.float64)
    tissue = (ct > 20) & (ct < 80)
    delay = np.linspace(2, 6, ct.shape[0])[:, None, None]
    frames = []
    for ti in t:
        s = np.clip(ti - delay, 0, None)
        bolus = 80 * (s / 4) ** 2 * np.exp(2 - s / 2) / 1.0
        frames.append(ct + tissue * np.minimum(bolus, 80) + rng.normal(0, 6, ct.shape))
    out.append(("perfusion", "held out", np.rint(np.stack(frames)).astype(np.int16)))
    mri = load("mri_ch2bet")[0][60:80].astype(np.float64) * 8
    d = 0.5 + 1.5 * (mri / max(mri.max(), 1))  # diffusivity, 1e-3 mm^2/s
    fibre = rng.normal(size=(3, *mri.shape))
    fibre /= np.linalg.norm(fibre, axis=0)
    dirs = rng.normal(size=(33, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    vols = [mri + rng.normal(0, 4, mri.shape)]  # b = 0
    for g in dirs[1:]:
        cos2 = np.einsum("i,i...->...", g, fibre) ** 2
        sig = mri * np.exp(-1.0 * d * (0.3 + 1.4 * cos2))
        vols.append(np.hypot(sig + rng.normal(0, 4, mri.shape), rng.normal(0, 4, mri.shape)))
    out.append(("dwi", "held out", np.rint(np.stack(vols)).clip(0, 65535).astype(np.uint16)))
    return out


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    measure.series = series
    measure.main(sys.argv[1])
