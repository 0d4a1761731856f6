"""Crops (40^3, 96^3), every second voxel and 4-slice slabs of real integer volumes: volpack lossless
against the peers (JPEG-XL e7/e9 and the rest of `volpack compare --peers`), one process.

Run: PYTHONPATH=. python results/lossy/exact33/trial_lossless.py OUT.csv NAME,NAME,...
"""

import csv
import sys
import time

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load

from volpack import api
from volpack.compare import compare_peers

NAMES = sys.argv[2].split(",")
rows = []
out = sys.argv[1]
for name in NAMES:
    v, _, _ = load(name)
    v = np.asarray(v)
    c = [s // 2 for s in v.shape]
    kinds = {
        "crop40": v[tuple(slice(max(0, ci - 20), ci + 20) for ci in c)],
        "crop96": v[tuple(slice(max(0, ci - 48), ci + 48) for ci in c)],
        "down2": v[::2, ::2, ::2],
        "slab4": v[c[0] - 2 : c[0] + 2],
    }
    for kind, a in kinds.items():
        a = np.ascontiguousarray(a)
        t = time.process_time()
        blob = api.compress_array(a, workers=1)
        enc = time.process_time() - t
        assert np.array_equal(api.decompress_array(blob), a)
        peers, _ = compare_peers(a, jpegxl_efforts=(7, 9))
        ok = [p for p in peers if p.get("lossless", True)]
        best = max(ok, key=lambda p: p["ratio"])
        r = a.nbytes / len(blob)
        row = dict(
            volume=name,
            kind=kind,
            shape="x".join(map(str, a.shape)),
            dtype=a.dtype.name,
            volpack=round(r, 4),
            best=best["name"],
            best_ratio=round(best["ratio"], 4),
            x=round(r / best["ratio"], 4),
            enc_s=round(enc, 2),
        )
        print(row, flush=True)
        rows.append(row)
with open(out, "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
