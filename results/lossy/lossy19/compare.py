"""Leads before -> after of two merged CSVs (volpack ratio over the best of SPERR, SZ3
and SZ3's best predictor), every cell, and the counts at 1.1x.

    python results/lossy/lossy19/compare.py BEFORE.csv AFTER.csv
"""
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from lossy18_merge import leads, read  # noqa: E402

before, after = (leads(read(Path(p))) for p in sys.argv[1:3])
rels = {}
for (d, b), (ratio, lead) in after.items():
    rels.setdefault(d, []).append(b)
for label, cells in (("before", before), ("after", after)):
    v = [x[1] for x in cells.values()]
    print(f"{label}: {sum(x >= 1.1 for x in v)} of {len(v)} at 1.1x, geometric mean "
          f"{math.exp(sum(map(math.log, v)) / len(v)):.3f}, lowest {min(v):.3f}")
for (d, b) in sorted(after):
    r0, l0 = before[(d, b)]
    r1, l1 = after[(d, b)]
    mark = "" if abs(r1 / r0 - 1) < 1e-4 else ("  +" if r1 > r0 else "  -")
    print(f"{d:18s} E={b:<11.4g} ratio {r0:8.3f} -> {r1:8.3f}  lead {l0:.3f} -> {l1:.3f}"
          f"{' MISS' if l1 < 1.1 else ''}{mark}")
