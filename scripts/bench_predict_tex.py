"""The texture bias (``predict_version=7``) against version 6, volpack alone, in one
process: for each volume the bytes of both (default bricks), the encoder's CPU seconds
(one run each) and the decoder's (best of ``--repeat``, the two blobs decoded in
alternation, each checked equal to the volume), and the tools the new default kept.

    python scripts/bench_predict_tex.py brainsmall mri_dipy_s0 --out results/lossless/lossless17

Output: ``OUT/predict_tex.csv`` (appended, one row per volume) and a line per volume.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

FIELDS = ["dataset", "shape", "dtype", "raw_bytes", "v6_bytes", "v7_bytes", "gain_pct",
          "v6_encode_cpu_s", "v7_encode_cpu_s", "v6_decode_cpu_s", "v7_decode_cpu_s", "tools_v7"]  # fmt: skip


def cpu(f):
    t = time.process_time()
    out = f()
    return out, time.process_time() - t


def main(argv: list[str] | None = None) -> int:
    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec.lossless import describe

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", metavar="NAME")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path, default=Path("results/lossless/lossless17"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "predict_tex.csv"
    new_file = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        if new_file:
            w.writeheader()
        for name in args.datasets:
            a, _, _ = datasets.load(name)
            blobs, enc, dec = {}, {}, {6: [], 7: []}
            for v in (6, 7):
                blobs[v], enc[v] = cpu(lambda: api.compress_array(a, predict_version=v))
            for _ in range(args.repeat):
                for v in (6, 7):
                    got, t = cpu(lambda: api.decompress_array(blobs[v], workers=1))
                    assert got.dtype == a.dtype and np.array_equal(got, a), name
                    dec[v].append(t)
            with Reader(blobs[7]) as r:
                tools = Counter(describe(p) for _, _, p in r)
            row = {
                "dataset": name, "shape": "x".join(map(str, a.shape)), "dtype": a.dtype.name,
                "raw_bytes": a.nbytes, "v6_bytes": len(blobs[6]), "v7_bytes": len(blobs[7]),
                "gain_pct": round(100 * (len(blobs[6]) / len(blobs[7]) - 1), 3),
                "v6_encode_cpu_s": round(enc[6], 3), "v7_encode_cpu_s": round(enc[7], 3),
                "v6_decode_cpu_s": round(min(dec[6]), 4), "v7_decode_cpu_s": round(min(dec[7]), 4),
                "tools_v7": " ".join(f"{k}:{n}" for k, n in sorted(tools.items())),
            }  # fmt: skip
            w.writerow(row)
            f.flush()
            print(
                f"{name}: ratio {a.nbytes / len(blobs[6]):.4f} -> {a.nbytes / len(blobs[7]):.4f} "
                f"({row['gain_pct']:+.2f} %), encode {enc[6]:.2f} -> {enc[7]:.2f} s, decode "
                f"{min(dec[6]):.3f} -> {min(dec[7]):.3f} s (x{min(dec[7]) / min(dec[6]):.3f}); {row['tools_v7']}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
