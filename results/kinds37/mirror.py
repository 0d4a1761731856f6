"""Why hydrogen_u8 (held out) is below zstd-19: mirror symmetry, and what coding half of
it would give. Run once after the held-out trial (the volume is no longer held out here).

    PYTHONPATH=. python results/kinds37/mirror.py DIR

For hydrogen_u8 and ml_u8: which axes the volume equals its own mirror image along, then
volpack's default lossless bytes and zstd-19's on the whole volume and on the part left
after taking out each mirrored half (what a coder that mirrors would code).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import zstandard

from volpack import api


def main() -> None:
    d = Path(sys.argv[1])
    for name in ("hydrogen_u8", "ml_u8"):
        a = np.load(d / f"{name}.npy")
        axes = [ax for ax in range(3) if np.array_equal(a, np.flip(a, ax))]
        print(f"{name} {a.shape}: equal to its mirror image along axes {axes} (z, y, x = 0, 1, 2)")
        part = a
        for ax in axes:
            part = part[(slice(None),) * ax + (slice(0, (a.shape[ax] + 1) // 2),)]
        for label, v in (("whole", a), (f"one part of 2^{len(axes)}", part)):
            v = np.ascontiguousarray(v)
            vb = len(api.compress_array(v))
            zb = len(zstandard.ZstdCompressor(level=19).compress(v.tobytes()))
            print(f"  {label} {v.shape}: volpack {vb:,} B, zstd-19 {zb:,} B; "
                  f"ratio of the whole volume at volpack's bytes {a.nbytes / vb:.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
