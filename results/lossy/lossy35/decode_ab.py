"""Decode CPU of the interpolation path's static bins with 18 tables (before) and shared
tables (after), one process, the two streams decoded in turn, best of ROUNDS each.

Run: PYTHONPATH=. python results/lossy/lossy35/decode_ab.py F.npy:REL[,F.npy:REL...] [ROUNDS]
"""

from __future__ import annotations

import sys
import time

import numpy as np

from volpack import api
from volpack.volume_codec import bounded_interp as bi


def main() -> None:
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 15
    for cell in sys.argv[1].split(","):
        path, rel = cell.rsplit(":", 1)
        x = np.load(path)
        blobs = []
        for on in (False, True):
            bi.SHARED_TABLES = on
            blobs.append(api.compress_array(x, rel_error=float(rel), workers=1))
        best = [np.inf, np.inf]
        outs = [api.decompress_array(b, workers=1) for b in blobs]  # warm
        for r in range(rounds):
            for i in (r % 2, 1 - r % 2):
                t = time.process_time()
                api.decompress_array(blobs[i], workers=1)
                best[i] = min(best[i], time.process_time() - t)
        same = np.array_equal(outs[0], outs[1], equal_nan=True)
        print(f"| {path.split('/')[-1][:-4]} | {rel} | {len(blobs[0]):,} -> {len(blobs[1]):,} "
              f"| {best[0] * 1e3:.2f} -> {best[1] * 1e3:.2f} ms ({best[0] / best[1]:.2f}x) | {same} |",
              flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
