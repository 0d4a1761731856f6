"""32^3 crops and every second voxel of real float fields at 1e-2..1e-5 of the range: volpack
(default effort) against SZ3 and SPERR (point-wise), every bound checked.

Run: PYTHONPATH=. python results/lossy/exact33/trial_lossy.py OUT.csv NAME,NAME,...
"""

import csv
import sys
import time

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load

from volpack import api
from volpack.compare import compare_peers

rows = []
out = sys.argv[1]
for name in sys.argv[2].split(","):
    v, _, _ = load(name)
    v = np.asarray(v, dtype=np.float32)
    c = [s // 2 for s in v.shape]
    kinds = {
        "crop32": v[tuple(slice(max(0, ci - 16), ci + 16) for ci in c)],
        "down2": v[::2, ::2, ::2],
    }
    for kind, a in kinds.items():
        a = np.ascontiguousarray(a)
        span = float(np.nanmax(a) - np.nanmin(a))
        for rel in (1e-2, 1e-3, 1e-4, 1e-5):
            e = rel * span
            t = time.process_time()
            blob = api.compress_array(a, rel_error=rel, workers=1)
            enc = time.process_time() - t
            back = api.decompress_array(blob)
            assert np.nanmax(np.abs(back.astype(np.float64) - a)) <= e
            peers, _ = compare_peers(a, max_error=e)
            held = [p for p in peers if p.get("bound_held") and p["name"] in ("sz3", "sperr")]
            best = max(held, key=lambda p: p["ratio"])
            r = a.nbytes / len(blob)
            row = dict(
                volume=name,
                kind=kind,
                shape="x".join(map(str, a.shape)),
                rel=rel,
                volpack=round(r, 3),
                best=best["name"],
                best_ratio=round(best["ratio"], 3),
                x=round(r / best["ratio"], 4),
                nbytes=len(blob),
                enc_s=round(enc, 2),
            )
            print(row, flush=True)
            rows.append(row)
with open(out, "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
