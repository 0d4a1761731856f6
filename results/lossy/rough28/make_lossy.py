"""The fields of ``results/unseen28/make.py`` (its generator), or one turbulence-like field
of another seed and slope.

``python make_lossy.py`` writes turb.npy, orbital.npy and mixing.npy (seed 28, as
unseen28 makes them); ``python make_lossy.py --seed S --slope P --name N`` writes only a
128^3 Gaussian field with power spectrum k^P, as N.npy (the held-out fields: seed 29,
slopes -11/3, -3, -13/3).
"""

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "unseen28"))
from make import fields, grf  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--seed", type=int, default=28)
ap.add_argument("--slope", type=float, default=None)
ap.add_argument("--name", default="turb")
args = ap.parse_args()
rng = np.random.default_rng(args.seed)
if args.slope is not None:
    f = grf(rng, 128, args.slope).astype(np.float32)
    np.save(args.name + ".npy", f)
    print(args.name, f.shape, f.min(), f.max())
else:
    for name, f in fields(rng).items():
        np.save(name + ".npy", f)
        print(name, f.shape, f.min(), f.max())
