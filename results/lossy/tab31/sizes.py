"""tab31: each arith decode of a cell (ldec31's streams): payload bytes, coefficients,
subtree roots, payload bits a coefficient (what decode's table rule reads).

    PYTHONPATH=. python results/lossy/tab31/sizes.py > results/lossy/tab31/sizes.txt
"""

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "ldec31"))
import cells  # noqa: E402

from volpack import api  # noqa: E402
from volpack.entropy import arith  # noqa: E402

seen = []
plain = arith.decode


def rec(data, scan, out):
    roots = int((scan.end > np.arange(1, scan.end.size + 1)).sum())
    seen.append((len(data), scan.perm.size, roots))
    return plain(data, scan, out)


arith.decode = rec
for c in (HERE / "cells.txt").read_text().strip().split(",")[1:]:
    n, _, r = c.partition(":")
    seen.clear()
    api.decompress_array(cells.blob(n, float(r)))
    for size, ncoef, roots in seen:
        print(n, r, size, ncoef, roots, f"{8 * size / ncoef:.3f} bits/coef")
