"""A/B of mode 7 (mirrored halves) in one process: each volume coded with
`lossless.MIRROR = False` and True (default lossless, one worker), the bytes compared,
CPU seconds of encode and decode (best of 2), every decode checked exact.

    PYTHONPATH=. python results/kinds37/ab_mirror.py DIR OUT.csv NAME ...

NAME: a file DIR/NAME.npy, or a corpus dataset of scripts/datasets.py.
"""

from __future__ import annotations

import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "scripts"))

from volpack import api  # noqa: E402
from volpack.volume_codec import lossless  # noqa: E402


def load(d: Path, name: str) -> np.ndarray:
    p = d / f"{name}.npy"
    if p.exists():
        return np.load(p)
    from datasets import load as dload

    return dload(name)[0]


def cpu(f):
    best = None
    for _ in range(2):
        t = time.process_time()
        out = f()
        dt = time.process_time() - t
        best = dt if best is None else min(best, dt)
    return out, best


def main() -> None:
    d, out, names = Path(sys.argv[1]), sys.argv[2], sys.argv[3:]
    rows = []
    for name in names:
        a = load(d, name)
        row = {"volume": name, "shape": "x".join(map(str, a.shape)), "dtype": a.dtype.name}
        for flag in (False, True):
            lossless.MIRROR = flag
            blob, enc = cpu(lambda a=a: api.compress_array(a, workers=1))
            back, dec = cpu(lambda blob=blob: api.decompress_array(blob, workers=1))
            assert np.array_equal(back.view(np.uint8), a.view(np.uint8)), name
            tag = "after" if flag else "before"
            row.update(
                {
                    f"bytes_{tag}": len(blob),
                    f"enc_cpu_{tag}": round(enc, 3),
                    f"dec_cpu_{tag}": round(dec, 4),
                }
            )
            row[f"blob_{tag}"] = blob
        row["same_bytes"] = row.pop("blob_before") == row.pop("blob_after")
        row["ratio_before"] = round(a.nbytes / row["bytes_before"], 3)
        row["ratio_after"] = round(a.nbytes / row["bytes_after"], 3)
        print(row, flush=True)
        rows.append(row)
    lossless.MIRROR = True
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
