"""What the complex64 refusal now suggests, done: make.py's k-space as two channels of
float32, (z, y, x, 2), coded by the default (fix 3 stores it as channels), against
byte-shuffled zstd -19 of the same bytes; the round trip checked bit for bit.

    PYTHONPATH=. python results/cli/user32/kspace.py DIR/kspace_c64.npy
"""

from __future__ import annotations

import sys
import time

import numpy as np
import zstandard

import volpack

k = np.load(sys.argv[1])
parts = np.stack([k.real, k.imag], -1)
t = time.process_time()
blob = volpack.compress_array(parts)
cpu = time.process_time() - t
assert volpack.decompress_array(blob).tobytes() == parts.tobytes()
shuffled = np.ascontiguousarray(parts.view(np.uint8).reshape(-1, 4).T).tobytes()
z = len(zstandard.ZstdCompressor(level=19).compress(shuffled))
print(
    f"kspace as (z,y,x,2) float32: ratio {parts.nbytes / len(blob):.3f} cpu {cpu:.1f} s; "
    f"zstd-19 byte-shuffled {parts.nbytes / z:.3f}"
)
