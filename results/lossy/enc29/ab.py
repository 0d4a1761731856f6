"""A/B in one process: the default effort's pruned selection (lossy.PRUNE) against the
exhaustive one, interleaved, best CPU time of ROUNDS encodes each, one worker.

    PYTHONPATH=. python results/lossy/enc29/ab.py OUT.csv FIELDS [--bounds 1e-2,..] [--rounds 2]

FIELDS: names of scripts/datasets.py, of bench.HELDOUT, 'tune' or 'heldout'; or .npy paths."""

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench import HELDOUT, TUNE, load_field  # noqa: E402

import volpack  # noqa: E402
from volpack import api  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402


def encode(x, e, prune):
    lossy.PRUNE = prune
    t = time.process_time()
    blob = api.compress_array(x, max_error=e, workers=1)
    return blob, time.process_time() - t


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("fields")
    ap.add_argument("--bounds", default="1e-2,1e-3,1e-4,1e-5")
    ap.add_argument("--rounds", type=int, default=2)
    a = ap.parse_args()
    print(volpack.__file__, file=sys.stderr)
    names = {"tune": TUNE, "heldout": HELDOUT}.get(a.fields) or a.fields.split(",")
    warm = np.cumsum(np.random.default_rng(0).standard_normal((24, 24, 24)), axis=2)
    coarse = (np.round(warm * 4) / 4).astype(np.float32)  # the exact path's kernels too
    for rel in (1e-2, 1e-3, 1e-5):
        for prune in (True, False):
            encode(warm.astype(np.float32), rel * 40, prune)
            encode(coarse, rel * 4, prune)
    rows = []
    for name in names:
        x = np.load(name) if name.endswith(".npy") else load_field(name)
        lo, hi = float(np.nanmin(x)), float(np.nanmax(x))
        for rel in (float(r) for r in a.bounds.split(",")):
            e = rel * (hi - lo)
            best = {True: np.inf, False: np.inf}
            size = {}
            for _ in range(a.rounds):
                for prune in (False, True):
                    blob, cpu = encode(x, e, prune)
                    best[prune] = min(best[prune], cpu)
                    size[prune] = len(blob)
                    if prune:  # every bound checked on every voxel
                        y = api.decompress_array(blob)
                        assert float(np.nanmax(np.abs(y.astype(np.float64) - x))) <= e
            row = (Path(name).stem, rel, size[False], size[True], round(best[False], 3),
                   round(best[True], 3))  # fmt: skip
            rows.append(row)
            print(*row, f"{best[False] / best[True]:.2f}x", file=sys.stderr, flush=True)
    with open(a.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["field", "rel", "bytes_exhaustive", "bytes_pruned", "cpu_exhaustive", "cpu_pruned"]
        )
        w.writerows(rows)


if __name__ == "__main__":
    main()
