"""A max-error bound's bytes must not change: sha256 of bounded files on 64^3 centre crops
of four tuning fields at 1e-2, 1e-3, 1e-4 of the range, and of a PSNR target's file on a
multi-brick field with 1 and 2 workers.

    cd CODE_DIR && PYTHONPATH=CODE_DIR python .../same_bytes.py DATA_DIR > OUT.txt
(run once with the base code's directory, once with this worktree; diff the outputs)
"""

import hashlib
import sys
from pathlib import Path

import numpy as np

from volpack import api


def crop(a, n=64):
    s = [max(0, (d - n) // 2) for d in a.shape]
    return np.ascontiguousarray(a[s[0] : s[0] + n, s[1] : s[1] + n, s[2] : s[2] + n])


def main():
    d = Path(sys.argv[1])
    for name in ("isabel_qcloud", "miranda_visc", "s3d_oh64", "nyx_vel"):
        a = crop(np.load(d / f"{name}.npy"))
        for rel in (1e-2, 1e-3, 1e-4):
            b = api.compress_array(a, rel_error=rel)
            print(name, rel, len(b), hashlib.sha256(b).hexdigest()[:16], flush=True)
    a = crop(np.load(d / "isabel_qcloud.npy"))
    for w in (1, 2):
        b = api.compress_array(a, psnr=45, brick=32, workers=w)
        print("isabel_qcloud crop psnr 45 brick 32 workers", w, len(b),
              hashlib.sha256(b).hexdigest()[:16], flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
