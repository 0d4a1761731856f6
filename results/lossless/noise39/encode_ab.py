"""Encode time with LOWM on and off (lossless.LOWM) in one process, best of 3 interleaved
runs, workers=1: the extra pass on bricks whose pick has LOW.

    PYTHONPATH=. python results/lossless/noise39/encode_ab.py F.npy ...
"""

from __future__ import annotations

import sys
import time

import numpy as np

from volpack import api
from volpack.volume_codec import lossless

print("| volume | encode time, LOWM on / off |")
print("|---|---:|")
for f in sys.argv[1:]:
    a = np.load(f)
    best = {}
    for _ in range(3):
        for on in (False, True):
            lossless.LOWM = on
            t = time.perf_counter()
            api.compress_array(a, workers=1)
            dt = time.perf_counter() - t
            best[on] = min(best.get(on, dt), dt)
    lossless.LOWM = True
    print(
        f"| {f.rsplit('/', 1)[-1].removesuffix('.npy')} | {best[True] / best[False]:.3f} |",
        flush=True,
    )
