"""A lower bound on the bits a voxel of any coder keeping every voxel of the synthetic
shock (results/unseen26/make.py) within E, from how it was made: the shock is a
deterministic field plus 0.05 g, g a Gaussian field (white noise filtered by |k|^-1.6,
normalised). Knowing the deterministic part can only help a coder, so R >= h(0.05 g) -
log2(2E) a voxel; h(0.05 g) from g's spectrum as bound.py does for the turbulence.

python results/lossy/rough28/shock_bound.py   (runs make.py in a temporary folder for g)
"""

import json
import os
import runpy
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[2]
sys.path.insert(0, str(HERE))
from bound import ks_bits  # noqa: E402

with tempfile.TemporaryDirectory() as tmp:
    cwd = os.getcwd()
    os.chdir(tmp)
    try:
        made = runpy.run_path(str(ROOT / "results/unseen26/make.py"))
    finally:
        os.chdir(cwd)
var, _ = ks_bits(0.05 * made["g"])
h = 0.5 * np.log2(2 * np.pi * np.e * var)
print(f"h(0.05 g) = {h:.3f} bits a voxel (differential)")
for e in ("1e-2", "1e-3", "1e-4", "1e-5"):
    d = json.loads((ROOT / f"results/unseen26/lossy/shock-{e}.json").read_text())
    c = d["compress"]
    p = {q["name"]: q for q in d["peers"]}
    best = max(p["sz3"]["ratio"], p["sperr"]["ratio"])
    slb = h - np.log2(2 * c["codec"]["max_error"])
    most = f"{32 / slb:.2f} ({32 / slb / best:.3f}x best peer)" if slb > 0 else "no bound"
    print(
        f"{e}: bound {slb:.3f} bits a voxel, ratio at most {most}; volpack {c['ratio']:.2f} "
        f"({c['ratio'] / best:.3f}x best peer {best:.2f})"
    )
