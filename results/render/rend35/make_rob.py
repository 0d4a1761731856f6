"""Inputs of the robustness trial (seeded; written to DIR): NaN, +-Inf, constant,
int32/float64/bool/int8 copies, 1:1:10 spacing, a 2-slice volume, a 1024^3 uint8 volume,
a 4-D series (for --gop and play), transparent and opaque TF files.

    PYTHONPATH=. python results/render/rend35/make_rob.py /tmp/rend35/rob
"""

import json
import sys
from pathlib import Path

import numpy as np

from scripts import datasets

out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
rng = np.random.default_rng(35)
x, _, _ = datasets.load("xray_1jzv")  # float32 70x76x96
x = np.ascontiguousarray(x, np.float32)

a = x.copy()
a[rng.random(a.shape) < 0.02] = np.nan
a[30:40, 30:40, 30:40] = np.nan
np.save(out / "nan.npy", a)
a = x.copy()
a[rng.random(a.shape) < 0.01] = np.inf
a[rng.random(a.shape) < 0.01] = -np.inf
np.save(out / "inf.npy", a)
a = x.copy()
a[rng.random(a.shape) < 0.01] = np.nan
a[rng.random(a.shape) < 0.01] = np.inf
np.save(out / "naninf.npy", a)
np.save(out / "const.npy", np.full((40, 50, 60), 7.0, np.float32))
np.save(out / "const_u8.npy", np.full((40, 50, 60), 200, np.uint8))
np.save(out / "allnan.npy", np.full((20, 20, 20), np.nan, np.float32))
s = (x - x.min()) / (x.max() - x.min())
np.save(out / "i32.npy", (s * 1e6).astype(np.int32))
np.save(out / "i32_big.npy", (s * 2e9 - 1e9).astype(np.int32))
np.save(out / "f64.npy", x.astype(np.float64))
np.save(out / "bool.npy", x > np.percentile(x, 90))
np.save(out / "i8.npy", (s * 255 - 128).astype(np.int8))
np.save(out / "u32.npy", (s * 4e9).astype(np.uint32))
np.save(out / "i64.npy", (s * 1e12).astype(np.int64))
np.save(out / "f16.npy", x.astype(np.float16))
np.save(out / "two_slices.npy", np.ascontiguousarray(x[30:32]))
np.save(out / "two_slices_x.npy", np.ascontiguousarray(x[:, :, 40:42]))
np.save(out / "x.npy", x)
# a 4-D series: the density drifting along x, 8 time steps
np.save(out / "series.npy", np.stack([np.roll(x, 2 * t, axis=2) for t in range(8)]))
(out / "transparent.json").write_text(json.dumps({"points": [[0, 1, 1, 1, 0], [1, 1, 1, 1, 0]],
                                                  "space": "normalized"}))
(out / "opaque.json").write_text(json.dumps({"points": [[0, 1, 0.8, 0.6, 1], [1, 1, 1, 1, 1]],
                                             "space": "normalized"}))
(out / "opaque_all.json").write_text(json.dumps({"points": [[-1e9, 1, 0.8, 0.6, 1], [1e9, 1, 1, 1, 1]],
                                                 "space": "value"}))
print("wrote", sorted(p.name for p in out.iterdir()))
