"""The default lossless encode of integer volumes: before (the exhaustive selection and
the fit's row-by-row sums, as the base tree codes), exhaustive (the selection of
``lossless.PRUNE = False`` with today's fit) and pruned (the default), interleaved in one
process; CPU seconds of ``api.compress_array`` (one worker), bytes, and the pruned file
decoded and compared voxel for voxel.

    PYTHONPATH=. python results/lossless/lenc30/ab.py OUT.csv NAME_OR_NPY... [--rounds N]
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import lossless, predictfit  # noqa: E402

MODES = {
    "before": (False, 0),
    "exhaustive": (False, predictfit.FIT_CHUNK),
    "pruned": (True, predictfit.FIT_CHUNK),
}


def volume(spec: str) -> np.ndarray:
    if spec.endswith(".npy"):
        return np.load(spec, mmap_mode="r")[...]
    return np.asarray(load(spec)[0])


def encode(a: np.ndarray, mode: str) -> tuple[bytes, float]:
    lossless.PRUNE, predictfit.FIT_CHUNK = MODES[mode]
    t = time.process_time()
    blob = api.compress_array(a, workers=1)
    return blob, time.process_time() - t


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--modes", default="before,exhaustive,pruned")
    args = ap.parse_args()
    modes = args.modes.split(",")
    warm = np.asarray(load("mri_dipy_aniso")[0])
    for m in modes:
        encode(warm, m)  # the kernels compile on first use
    ratios = []
    with open(args.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(
            ["volume", "shape", "dtype", "mode", "bytes", "cpu_s", "same_as_before", "exact"]
        )
        for spec in args.volumes:
            a = volume(spec)
            if a.dtype.kind not in "iu":
                continue
            best, blobs = {}, {}
            for r in range(args.rounds):
                for m in modes if r % 2 == 0 else modes[::-1]:
                    blob, t = encode(a, m)
                    best[m] = min(best.get(m, math.inf), t)
                    blobs[m] = blob
            lossless.PRUNE = True
            exact = np.array_equal(api.decompress_array(blobs[modes[-1]]), a)
            for m in modes:
                same = blobs[m] == blobs.get("before") if "before" in blobs else ""
                w.writerow(
                    [
                        spec,
                        "x".join(map(str, a.shape)),
                        a.dtype,
                        m,
                        len(blobs[m]),
                        f"{best[m]:.3f}",
                        same,
                        exact if m == modes[-1] else "",
                    ]
                )
            f.flush()
            b0, b1 = modes[0], modes[-1]
            ratios.append(best[b0] / best[b1])
            print(
                f"{spec:24s} {len(blobs[b0]):>10d} -> {len(blobs[b1]):>10d} "
                f"({100 * (len(blobs[b1]) / len(blobs[b0]) - 1):+.3f} %)  "
                f"{best[b0]:7.2f} -> {best[b1]:6.2f} s ({best[b0] / best[b1]:.2f}x)"
                + (
                    ""
                    if "exhaustive" not in blobs
                    else f"  exhaustive {best['exhaustive']:.2f} s same {blobs['exhaustive'] == blobs[b0]}"
                )
                + f"  exact {exact}",
                flush=True,
            )
    print(
        f"geometric mean speed-up {math.exp(sum(map(math.log, ratios)) / len(ratios)):.3f}x over {len(ratios)}"
    )


if __name__ == "__main__":
    main()
