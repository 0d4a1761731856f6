"""The Shannon bound of make.py's low-count Poisson volume: the entropy of each voxel's
Poisson law at its true rate (known here, as no coder knows it), summed, against volpack's
file and the best peer's (from trial.csv).

    PYTHONPATH=. python results/lossless/kinds34/poisson_bound.py DIR
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np
from scipy import ndimage, stats

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402


def main(d: Path) -> None:
    ch2 = load("mri_ch2")[0]
    lam = ndimage.gaussian_filter(ch2.astype(np.float64), 2.0)
    lam = lam * (5 / lam.max())  # make.py's poisson5_u16 rate
    a = np.load(d / "poisson5_u16.npy")
    ks = np.arange(0, 40)
    # entropy of Poisson(l) in bits, tabulated over a fine grid of rates
    grid = np.linspace(0, 5, 5001)
    pmf = stats.poisson.pmf(ks[None, :], grid[:, None])
    with np.errstate(divide="ignore", invalid="ignore"):
        h = -np.nansum(np.where(pmf > 0, pmf * np.log2(pmf), 0.0), axis=1)
    bits = np.interp(lam.reshape(-1), grid, h).sum()
    bound = bits / 8
    with open(Path(__file__).parent / "trial.csv") as f:
        row = next(r for r in csv.DictReader(f) if r["volume"] == "poisson5_u16")
    ours, peer = int(row["bytes"]), a.nbytes / float(row["peer_ratio"])
    print(f"bound {bound:.0f} B (ratio {a.nbytes / bound:.3f}); volpack {ours} B ({ours / bound:.3f}x "
          f"the bound); {row['best_peer']} {peer:.0f} B ({peer / bound:.3f}x the bound); "
          f"1.1x the peer needs {peer / 1.1:.0f} B ({peer / 1.1 / bound:.3f}x the bound)")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
