"""The fitted float predictor (``predict_version=6``) against version 5, volpack alone,
in one process: for each volume the bytes of both versions (version 6 only adds mode 5's
tool 3 as a candidate, so version 5's bytes are the files before it), every blob
decoded and compared bit for bit, and the CPU seconds of ``api.compress_array`` and
``api.decompress_array`` (one worker), best of ``--repeat``, the two versions
alternating in each round.

    python scripts/bench_float_fit.py tgv_u cam_u --repeat 5 --out results/lossless/float16
    python scripts/bench_float_fit.py cam_u --versions 9 10 --out results/lossless/float21

Output: ``OUT/float_fit.csv`` (``OUT/float_fit_vA_vB.csv`` for other ``--versions A B``;
appended, one row per volume) and a line per volume.
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
    parser.add_argument("--versions", type=int, nargs=2, default=(5, 6), metavar=("OLD", "NEW"))
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    vo, vn = versions = tuple(args.versions)
    path = args.out / ("float_fit.csv" if versions == (5, 6) else f"float_fit_v{vo}_v{vn}.csv")
    new_file = not path.exists()
    with open(path, "a", newline="") as f:
        w = csv.writer(f)
        if new_file:
            w.writerow(
                ["dataset", "shape", "dtype", "raw_bytes", f"v{vo}_bytes", f"v{vn}_bytes",
                 f"v{vn}_tools", f"v{vo}_enc_mb_s", f"v{vn}_enc_mb_s", f"v{vo}_dec_mb_s",
                 f"v{vn}_dec_mb_s", "repeat", "load"]
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
            tools = api.info(blobs[vn])["summary"].get("tools", {})
            shape = "x".join(map(str, a.shape))
            e = {v: mb / min(enc[v]) for v in versions}
            d = {v: mb / min(dec[v]) for v in versions}
            load = f"{__import__('os').getloadavg()[0]:.1f}"
            w.writerow(
                [name, shape, a.dtype, a.nbytes, len(blobs[vo]), len(blobs[vn]), tools,
                 f"{e[vo]:.2f}", f"{e[vn]:.2f}", f"{d[vo]:.2f}", f"{d[vn]:.2f}", args.repeat, load]
            )  # fmt: skip
            f.flush()
            r5, r6 = a.nbytes / len(blobs[vo]), a.nbytes / len(blobs[vn])
            print(
                f"{name} {shape}: ratio v{vo} {r5:.4f} v{vn} {r6:.4f} "
                f"({100 * (r6 / r5 - 1):+.2f} %) {tools}; "
                f"encode MB/s {e[vo]:.2f} -> {e[vn]:.2f}; "
                f"decode MB/s {d[vo]:.1f} -> {d[vn]:.1f} ({d[vn] / d[vo]:.2f}x); load {load}",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
