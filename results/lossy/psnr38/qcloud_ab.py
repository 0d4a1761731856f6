"""isabel_qcloud: PSNR and bits against the error bound with each brick's coding chosen by
size (rd = 0, what an error bound keeps) and by rate and distortion (rd = RD_WEIGHT, what
a PSNR target now keeps), side by side in one process (psnr37's qcloud_sweep.py bounds).

    PYTHONPATH=. python results/lossy/psnr38/qcloud_ab.py DATA_DIR > qcloud_ab.txt
"""

import math
import sys
import time
from pathlib import Path

import numpy as np

from volpack.volume_codec.lossy import RD_WEIGHT, BoundedCodec


def main():
    a = np.load(Path(sys.argv[1]) / "isabel_qcloud.npy")  # one brick, as the CLI codes it
    lo, hi = float(a.min()), float(a.max())
    rng, zero = hi - lo, a == 0
    print(f"isabel_qcloud {a.shape}, range {rng:.6g}, exact zeros {zero.mean():.3f}")
    for e in np.geomspace(1.2e-4, 1.2e-3, 13):
        row = [f"E {e:.4g}"]
        for label, rd in (("size", 0.0), ("rd", RD_WEIGHT)):
            c = BoundedCodec.plan(a.dtype, lo, hi, float(e), rd=rd)
            t = time.process_time()
            p, _, sse, n = c.encode_measured(a)
            t = time.process_time() - t
            o = c.decode(p, a.shape, a.dtype)
            psnr = 20 * math.log10(rng) - 10 * math.log10(sse / n)
            row.append(f"{label}: {8 * len(p) / a.size:.4f} bpv {psnr:6.2f} dB zeros kept "
                       f"{(o[zero] == 0).mean():.3f} flag {p[0]:3d} {t:5.1f} s")  # fmt: skip
        print(" | ".join(row), flush=True)


if __name__ == "__main__":
    main()
