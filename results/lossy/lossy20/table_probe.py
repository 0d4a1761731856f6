"""The static residual's tables (type 4, first version: no sign symbols) on a cell: their
bytes as fastpredict packs them (LEB128), zstd'd, and as differences from the previous
class's table zstd'd.

    python results/lossy/lossy20/table_probe.py tas_monthly:1e-5
"""
import sys

import numpy as np
from common import residuals
from static_probe import contexts, tokens

from volpack.format.deflate import deflate
from volpack.volume_codec import fastpredict as fp
from volpack.volume_codec import palette as pal

for name, rel, a, codec, q, (r, plan, w) in residuals(sys.argv[1]):
    flat = r.reshape(-1)
    act, _ = contexts(flat, *r.shape)
    tok, _ = tokens(flat)
    counts = np.zeros((fp.NCLASS, 256), np.int64)
    np.add.at(counts, (act, tok), 1)
    nctx, freqs, cost = fp.cap_contexts(counts)
    packed = fp.pack_tables(freqs)
    prev = np.zeros(freqs.shape[1], np.int64)
    delta = bytearray()
    for row in freqs:
        delta += b"".join(pal.uleb(int(2 * v if v >= 0 else -2 * v - 1)) for v in row - prev)
        prev = row
    print(f"{name} {rel}: {nctx} classes, tables {len(packed)} B, zstd {len(deflate(packed))} B, "
          f"deltas zstd {len(deflate(bytes(delta)))} B", flush=True)
