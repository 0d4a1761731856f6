"""The static residual's tables (type 4) on a cell: their bytes as fastpredict packs them
(LEB128), zstd'd, and as differences from the previous class's table zstd'd.

    python results/lossy/lossy20/table_probe.py tas_monthly:1e-5
"""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lossy19"))
from cells import cells, quantised  # noqa: E402

from volpack.format.deflate import deflate  # noqa: E402
from volpack.volume_codec import bounded_longfit as lf  # noqa: E402
from volpack.volume_codec import fastpredict as fp  # noqa: E402
from volpack.volume_codec import palette as pal  # noqa: E402

for name, rel, a, e in cells(sys.argv[1]):
    for codec, q, _ in quantised(a, e):
        reach = lf.tried_reaches(np.ascontiguousarray(q, np.int64))[-1]
        r, plan, w = lf.residuals(q, reach, int(np.iinfo(q.dtype).max), prune=True)
        flat = r.reshape(-1)
        toks = np.empty(flat.size, np.uint8)
        ctxs = np.empty(flat.size, np.uint8)
        counts = np.zeros((fp.NCLASS, 256), np.int64)
        bits = np.zeros(5 * flat.size + 16, np.uint8)
        lf._static_tokens(flat, *r.shape, toks, ctxs, counts, bits)
        for label, (nctx, freqs, cost) in (("capped", fp._cap_contexts(counts)),):
            packed = fp.pack_tables(freqs)
            prev = np.zeros(freqs.shape[1], np.int64)
            delta = bytearray()
            for row in freqs:
                d = row - prev
                delta += b"".join(pal.uleb(int(2 * v if v >= 0 else -2 * v - 1)) for v in d)
                prev = row
            print(f"{name} {rel}: {nctx} classes, tables {len(packed)} B, zstd {len(deflate(packed))} B, "
                  f"deltas zstd {len(deflate(bytes(delta)))} B; symbols+raw {cost / 8 - len(packed):.0f} B", flush=True)
