"""Float fields coded exactly, whole and at every second voxel: volpack's lossless file
against the best lossless peer of ``volpack compare --peers`` (pcodec, fpzip, zstd, blosc2;
no JPEG-XL), one process.

Run: PYTHONPATH=. python results/lossy/exact33/trial_float_lossless.py OUT.csv
"""

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import DATASETS, load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.compare import compare_peers  # noqa: E402

rows = []
for name in [n for n, d in DATASETS.items() if d.kind == "float"]:
    v = np.asarray(load(name)[0])
    for kind, a in (("whole", v), ("every 2nd", v[::2, ::2, ::2])):
        a = np.ascontiguousarray(a)
        if a.size > 3_000_000:
            continue
        blob = api.compress_array(a, workers=1)
        assert np.array_equal(api.decompress_array(blob).view(np.uint8), a.view(np.uint8))
        peers, _ = compare_peers(a, jpegxl_efforts=())
        best = max(peers, key=lambda p: p["ratio"])
        r = a.nbytes / len(blob)
        row = dict(volume=name, kind=kind, shape="x".join(map(str, a.shape)), volpack=round(r, 4),
                   best=best["name"], best_ratio=round(best["ratio"], 4), x=round(r / best["ratio"], 4))  # fmt: skip
        print(row, flush=True)
        rows.append(row)
with open(sys.argv[1], "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
