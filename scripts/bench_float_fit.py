"""The fitted float predictor (``predict_version=6``) against version 5, volpack alone,
in one process: for each volume the bytes of both versions (version 6 only adds mode 5's
tool 3 as a candidate, so version 5's bytes are the files before it), every blob
decoded and compared bit for bit, and the CPU seconds of ``api.compress_array`` and
``api.decompress_array`` (one worker), best of ``--repeat``, the two versions
alternating in each round.

    python scripts/bench_float_fit.py tgv_u cam_u --repeat 5 --out results/lossless/float16

Output: ``OUT/float_fit.csv`` (appended, one row per volume) and a line per volume.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def cpu(fn) -> tuple[float, object]:
    t = time.process_time()
    out = fn()
    return time.process_time() - t, out


def main(argv: list[str] | None = None) -> int:
    from volpack import api

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", metavar="NAME")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--encode-repeat", type=int, default=1)
    parser.add_argument("--out", type=Path, default=Path("results/lossless/float16"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "float_fit.csv"
    new_file = not path.exists()
    versions = (5, 6)
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new_file:
            w.writerow(
                ["dataset", "shape", "dtype", "raw_bytes", "v5_bytes", "v6_bytes", "v6_tools",
                 "v5_enc_mb_s", "v6_enc_mb_s", "v5_dec_mb_s", "v6_dec_mb_s", "repeat", "load"]
            )  # fmt: skip
        for name in args.datasets:
            a, _, _ = datasets.load(name)
            mb = a.nbytes / 1e6
            enc = {v: [] for v in versions}
            blobs = {}
            for _ in range(args.encode_repeat):
                for v in versions:
                    run = lambda v=v: api.compress_array(a, predict_version=v, workers=1)  # noqa: E731
                    t, blobs[v] = cpu(run)
                    enc[v].append(t)
            dec = {v: [] for v in versions}
            for _ in range(args.repeat):
                for v in versions:
                    t, got = cpu(lambda v=v: api.decompress_array(blobs[v], workers=1))
                    dec[v].append(t)
                    if not np.array_equal(
                        got.reshape(-1).view(f"u{a.itemsize}"),
                        np.ascontiguousarray(a).reshape(-1).view(f"u{a.itemsize}"),
                    ):
                        raise AssertionError(f"{name}: version {v} is not bit exact")
            tools = api.info(blobs[6])["summary"].get("tools", {})
            shape = "x".join(map(str, a.shape))
            e = {v: mb / min(enc[v]) for v in versions}
            d = {v: mb / min(dec[v]) for v in versions}
            load = f"{__import__('os').getloadavg()[0]:.1f}"
            w.writerow(
                [name, shape, a.dtype, a.nbytes, len(blobs[5]), len(blobs[6]), tools,
                 f"{e[5]:.2f}", f"{e[6]:.2f}", f"{d[5]:.2f}", f"{d[6]:.2f}", args.repeat, load]
            )  # fmt: skip
            f.flush()
            r5, r6 = a.nbytes / len(blobs[5]), a.nbytes / len(blobs[6])
            print(
                f"{name} {shape}: ratio v5 {r5:.4f} v6 {r6:.4f} "
                f"({100 * (r6 / r5 - 1):+.2f} %) {tools}; "
                f"encode MB/s {e[5]:.2f} -> {e[6]:.2f}; decode MB/s {d[5]:.1f} -> {d[6]:.1f} "
                f"({d[6] / d[5]:.2f}x); load {load}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
