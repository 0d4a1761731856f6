"""Where mode 8 is even tried: gain.find on every 128^3 brick (as `volpack compress` cuts
them) of the corpus's integer volumes (scripts/datasets.py) and of the trial's tuned
volumes; the count of bricks it finds a comb in, and the time it takes.

    PYTHONPATH=. python results/kinds38/gain_triggers.py DATA_DIR
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "scripts"))
from datasets import load, names  # noqa: E402

from volpack.volume_codec import gain  # noqa: E402


def bricks(a, b=128):
    for z in range(0, a.shape[0], b):
        for y in range(0, a.shape[1], b):
            for x in range(0, a.shape[2], b):
                yield np.ascontiguousarray(a[z : z + b, y : y + b, x : x + b])


def main():
    d = Path(sys.argv[1])
    vols = [(n, lambda n=n: load(n)[0]) for n in names()]
    for line in open(d / "volumes.txt"):
        n, kind, held = line.split("\t")[:3]
        if kind == "int" and held == "tuned":
            vols.append((n, lambda n=n: np.load(d / f"{n}.npy")))
    total = 0
    for name, get in vols:
        a = get()
        if a.dtype.kind not in "iu" or a.ndim != 3:
            continue
        t = time.process_time()
        found = [gain.find(b) for b in bricks(a)]
        dt = time.process_time() - t
        total += dt
        hits = [f for f in found if f]
        print(
            f"{name:26s} {str(a.dtype):7s} bricks {len(found):3d} combs {len(hits):3d} {hits[:3]} find {dt:.3f} s",
            flush=True,
        )
    print(f"find in all: {total:.2f} s CPU")


if __name__ == "__main__":
    main()
