"""Decoding speed of the long fit with its residual context coded (step 22) against
what the encoder keeps without it, on one cell, in one process (CPU s, best of 7,
interleaved): is it a middle-tier coding (as the interpolation path's adaptive bins) or
a slow one (as the lossless codec's predictor)?

    python results/lossy/lossy19/tier_probe.py tgv_pressure:1e-5,tgv_vorticity:1e-3
"""
import sys
import time

import numpy as np
from cells import cells

from volpack import api
from volpack.format.container import Reader
from volpack.volume_codec import lossy

for name, rel, a, e in cells(sys.argv[1]):
    kept = api.compress_array(a, max_error=e)
    slow = lossy.TIER_SLOW
    lossy.TIER_SLOW = lossy.TIER_MID  # every coding in one tier: the shortest is kept
    try:
        short = api.compress_array(a, max_error=e)
    finally:
        lossy.TIER_SLOW = slow
    blobs = {"kept": kept, "shortest": short}
    times = {k: [] for k in blobs}
    for k, b in blobs.items():
        assert np.abs(api.decompress_array(b).astype(np.float64) - a).max() <= e
    for i in range(7):
        for k in (list(blobs) if i % 2 else list(blobs)[::-1]):
            t0 = time.process_time()
            api.decompress_array(blobs[k])
            times[k].append(time.process_time() - t0)
    flags = {}
    for k, b in blobs.items():
        with Reader(b) as r:
            flags[k] = [p[0] for _, _, p in r]
    mb = a.nbytes / 1e6
    print(f"{name} {rel}: " + ", ".join(
        f"{k} {len(blobs[k])} B flags {flags[k]} {1e3 * min(times[k]):.1f} ms "
        f"({mb / min(times[k]):.0f} MB/s)" for k in blobs), flush=True)
