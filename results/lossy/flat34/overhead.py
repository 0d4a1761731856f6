"""Why small 2-D fields fall below 1.1x: for each cell of trial.csv under 1.1x the best of
SZ3/SPERR, the file's bytes against its payload's (the bricks' coded bytes; the rest is
the container's header, index and summary) and the peer's ratio on the payload alone.

Run: PYTHONPATH=. python results/lossy/flat34/overhead.py trial.csv OUT.csv
"""

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from trial import arrays  # noqa: E402

from volpack import api  # noqa: E402

cells = [r for r in csv.DictReader(open(sys.argv[1])) if float(r["x_best"]) < 1.1]
want = {r["array"] for r in cells}
rows = []
for label, a, _ in arrays(None):
    if label not in want:
        continue
    a = np.ascontiguousarray(a)
    for r in (c for c in cells if c["array"] == label):
        blob = api.compress_array(a, rel_error=float(r["rel"]), workers=1)
        assert len(blob) == int(r["bytes"]), (label, r["rel"])
        pay = api.info(blob)["payload_nbytes"]
        peer = float(r["x_best"]) * len(blob)
        row = {"array": label, "shape": r["shape"], "set": r["set"], "rel": r["rel"],
               "file": len(blob), "payload": pay, "overhead": len(blob) - pay,
               "peer": r["best_peer"], "peer_bytes": round(peer), "x_file": r["x_best"],
               "x_payload": round(peer / pay, 4)}  # fmt: skip
        print(row, flush=True)
        rows.append(row)
with open(sys.argv[2], "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
