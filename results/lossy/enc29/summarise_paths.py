"""Per cell: each path's shortest payload (bytes, CPU s) and the kept size, from bench.py --paths."""

import csv
import sys
from collections import defaultdict

rows = [r for r in csv.DictReader(open(sys.argv[1])) if r["cell"]]
cells = defaultdict(list)
for r in rows:
    cells[r["cell"]].append(r)
P = [
    "_code_quantised",
    "_coef_candidate",
    "_cdf97_candidates",
    "_interp_candidate",
    "_longfit",
    "_exact_candidate",
]
short = {
    "_code_quantised": "qv",
    "_coef_candidate": "coef",
    "_cdf97_candidates": "cdf",
    "_interp_candidate": "int",
    "_longfit": "long",
    "_exact_candidate": "exact",
}
print("cell".ljust(26), " ".join(f"{short[p]:>14}" for p in P), "kept")
for c, rs in cells.items():
    kept = min(int(r["bytes"]) for r in rs if r["path"] == "_encode_masked")
    out = []
    for p in P:
        b = [int(x) for r in rs if r["path"] == p for x in r["bytes"].split(";") if x]
        t = sum(float(r["cpu_s"]) for r in rs if r["path"] == p)
        out.append(f"{(min(b) / kept - 1) * 100:+6.1f}%/{t:5.2f}" if b else f"{'-':>6}/{t:5.2f}")
    print(c.ljust(26), " ".join(f"{o:>14}" for o in out), kept)
