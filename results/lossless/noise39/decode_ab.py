"""Decode speed A/B in one process: the base tree's decoder (a copy of /work/main's
volpack, 651bd2c's library, imported as volpack_base: PYTHONPATH=BASE_COPY:.) against
this branch's, on the same stream without LOWM (the cost of the new branches on old
streams), and this branch's on the LOWM stream against the stream without it. Best of
N interleaved runs each, workers=1.

    PYTHONPATH=/tmp/n39/basepkg:. python results/lossless/noise39/decode_ab.py F.npy ...
"""

from __future__ import annotations

import sys
import time

import numpy as np
import volpack_base.api as base_api

from volpack import api
from volpack.volume_codec import lossless

N = 7
print(
    "| volume | MB | new / base decoder, stream without LOWM | LOWM stream / without, new decoder | MB/s new on LOWM |"
)
print("|---|---:|---:|---:|---:|")
for f in sys.argv[1:]:
    a = np.load(f)
    lossless.LOWM = False
    plain = api.compress_array(a, workers=1)
    lossless.LOWM = True
    lowm = api.compress_array(a, workers=1)
    calls = {
        "base": lambda plain=plain: base_api.decompress_array(plain, workers=1),
        "new": lambda plain=plain: api.decompress_array(plain, workers=1),
        "lowm": lambda lowm=lowm: api.decompress_array(lowm, workers=1),
    }
    best = {}
    for _ in range(N):
        for k, call in calls.items():
            t = time.perf_counter()
            out = call()
            dt = time.perf_counter() - t
            assert np.array_equal(out, a), (f, k)
            best[k] = min(best.get(k, dt), dt)
    mb = a.nbytes / 1e6
    name = f.rsplit("/", 1)[-1].removesuffix(".npy")
    print(
        f"| {name} | {mb:.2f} | {best['new'] / best['base']:.3f} | {best['lowm'] / best['new']:.3f} | "
        f"{mb / best['lowm']:.1f} |",
        flush=True,
    )
