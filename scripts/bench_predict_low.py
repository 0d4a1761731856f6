"""The low-value models (``predict_version=5``) and the small-volume brick against the
previous default, volpack alone, in one process: for each volume the bytes of
``predict_version=4`` with 64^3 bricks (main's default before issue 20's change),
version 5 in 64^3 bricks, and the new default (version 5, 128^3 bricks for integer
volumes of at most 2^21 voxels). Every blob is decoded and compared.

    python scripts/bench_predict_low.py brainsmall mri_dipy_s0 --out results/lossless/lossless10

Output: ``OUT/predict_low.csv`` (appended, one row per volume) and the table on stdout.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    from volpack import api

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", metavar="NAME")
    parser.add_argument("--out", type=Path, default=Path("results/lossless/lossless10"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "predict_low.csv"
    new_file = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new_file:
            w.writerow(["dataset", "shape", "dtype", "raw_bytes", "v4_b64", "v5_b64", "v5_default", "tools_default"])
        for name in args.datasets:
            a, _, _ = datasets.load(name)
            blobs = [
                api.compress_array(a, predict_version=4, brick=64),
                api.compress_array(a, brick=64),
                api.compress_array(a),
            ]
            for b in blobs:
                if not np.array_equal(api.decompress_array(b), a):
                    raise AssertionError(f"{name}: no round trip")
            tools = api.info(blobs[2])["summary"].get("tools", {})
            shape = "x".join(map(str, a.shape))
            w.writerow([name, shape, a.dtype, a.nbytes, *map(len, blobs), tools])
            f.flush()
            r = [a.nbytes / len(b) for b in blobs]
            print(f"{name} {shape} {a.dtype}: ratio v4/64 {r[0]:.4f}  v5/64 {r[1]:.4f}  "
                  f"v5 default {r[2]:.4f} ({100 * (r[2] / r[0] - 1):+.2f} %) {tools}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
