"""A/B, interleaved in one process: the default lossy encode (one worker) with the scan
caches unbounded ("kept": every scan made stays, as the entry-count caches before session
30 kept a brick shape's six) and bounded by sigmap.SCAN_CACHE_BYTES ("bounded"), best CPU
time of ROUNDS encodes each after a warm-up round; the bytes must not change.

    PYTHONPATH=. python results/lossy/mem30/ab_cache.py FIELD.npy [--rel 1e-3] [--rounds 2]
"""

import sys
import time

import numpy as np
from common import field_and_bound

from volpack import api
from volpack.wavelet import sigmap

BOUND = sigmap.SCAN_CACHE_BYTES


def main():
    a, x, e = field_and_bound(("--rounds", int, 2))
    best, blobs = {}, {}
    for r in range(a.rounds + 1):  # round 0 warms up (kernels, first scans)
        for mode, limit in (("kept", 1 << 50), ("bounded", BOUND)):
            sigmap.SCAN_CACHE_BYTES = limit
            t = time.process_time()
            blobs[mode] = api.compress_array(x, max_error=e, workers=1)
            cpu = time.process_time() - t
            if r:
                best[mode] = min(best.get(mode, np.inf), cpu)
            print(r, mode, round(cpu, 2), file=sys.stderr, flush=True)
    assert blobs["kept"] == blobs["bounded"]
    print(
        f"{a.field} {a.rel}: kept {best['kept']:.2f} s, bounded {best['bounded']:.2f} s, "
        f"{best['bounded'] / best['kept']:.3f}x"
    )


if __name__ == "__main__":
    main()
