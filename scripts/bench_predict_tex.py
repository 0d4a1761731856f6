"""One ``predict_version`` against another, volpack alone, in one process (by default the
texture bias, version 7, against version 6; ``--versions 7 8``: the mixed estimates):
for each volume the bytes of both (default bricks), the encoder's CPU seconds (one run
each) and the decoder's (best of ``--repeat``, the two blobs decoded in alternation,
each checked equal to the volume), and the tools the newer version kept.

    python scripts/bench_predict_tex.py brainsmall mri_dipy_s0 --out results/lossless/lossless17
    python scripts/bench_predict_tex.py brainsmall --versions 7 8 --out results/lossless/lossless18

Output: ``OUT/predict_tex.csv`` (6 against 7) or ``OUT/predict_vA_vB.csv`` (appended,
one row per volume) and a line per volume.
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



def fields(old: int, new: int) -> list[str]:
    f = ["dataset", "shape", "dtype", "raw_bytes", "v{}_bytes", "v{}_bytes", "gain_pct",
         "v{}_encode_cpu_s", "v{}_encode_cpu_s", "v{}_decode_cpu_s", "v{}_decode_cpu_s", "tools_v{}"]  # fmt: skip
    vs = iter([old, new, old, new, old, new, new])
    return [k.format(next(vs)) if "{}" in k else k for k in f]


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
    parser.add_argument("--versions", type=int, nargs=2, default=[6, 7], metavar=("OLD", "NEW"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    o, n = args.versions
    name = "predict_tex.csv" if (o, n) == (6, 7) else f"predict_v{o}_v{n}.csv"
    path = args.out / name
    new_file = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.DictWriter(f, fields(o, n))
        if new_file:
            w.writeheader()
        for name in args.datasets:
            a, _, _ = datasets.load(name)
            blobs, enc, dec = {}, {}, {o: [], n: []}
            for v in (o, n):
                blobs[v], enc[v] = cpu(lambda: api.compress_array(a, predict_version=v))
            for _ in range(args.repeat):
                for v in (o, n):
                    got, t = cpu(lambda: api.decompress_array(blobs[v], workers=1))
                    assert got.dtype == a.dtype and np.array_equal(got, a), name
                    dec[v].append(t)
            with Reader(blobs[n]) as r:
                tools = Counter(describe(p) for _, _, p in r)
            row = {
                "dataset": name, "shape": "x".join(map(str, a.shape)), "dtype": a.dtype.name,
                f"v{o}_bytes": len(blobs[o]), f"v{n}_bytes": len(blobs[n]),
                "gain_pct": round(100 * (len(blobs[o]) / len(blobs[n]) - 1), 3),
                f"v{o}_encode_cpu_s": round(enc[o], 3), f"v{n}_encode_cpu_s": round(enc[n], 3),
                f"v{o}_decode_cpu_s": round(min(dec[o]), 4), f"v{n}_decode_cpu_s": round(min(dec[n]), 4),
                f"tools_v{n}": " ".join(f"{k}:{c}" for k, c in sorted(tools.items())),
            }  # fmt: skip
            w.writerow(row)
            f.flush()
            print(
                f"{name}: ratio {a.nbytes / len(blobs[o]):.4f} -> {a.nbytes / len(blobs[n]):.4f} "
                f"({row['gain_pct']:+.2f} %), encode {enc[o]:.2f} -> {enc[n]:.2f} s, decode "
                f"{min(dec[o]):.3f} -> {min(dec[n]):.3f} s (x{min(dec[n]) / min(dec[o]):.3f}); "
                f"{row[f'tools_v{n}']}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
