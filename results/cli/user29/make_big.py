"""The two big volumes of session 29's command-line runs (findings.md):

- ct512.npy: ct_head (108x256x256 int16 HU) resampled trilinearly to 512^3, shifted to
  uint16 (+1024) with Gaussian noise of sigma 4 (seed 29): 268 MB;
- field384.npy: tgv_vorticity resampled trilinearly to 384^3 float32: 226 MB.

Run: PYTHONPATH=. python results/cli/user29/make_big.py OUT_DIR
"""

import sys
from pathlib import Path

import numpy as np
from scipy import ndimage

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def resampled(name: str, n: int) -> np.ndarray:
    a = load(name)[0].astype(np.float32)
    return ndimage.zoom(a, [n / s for s in a.shape], order=1, output=np.float32)


def main(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    ct = resampled("ct_head", 512)
    ct += np.random.default_rng(29).normal(0, 4, ct.shape).astype(np.float32)
    np.save(out / "ct512.npy", np.clip(np.rint(ct + 1024), 0, 65535).astype(np.uint16))
    del ct
    np.save(out / "field384.npy", resampled("tgv_vorticity", 384))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
