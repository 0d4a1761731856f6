"""Decode time of the lossless codec's predictive stream version 2 against version 1, in
one process on the same array, alternating, CPU seconds (``time.process_time``).

For each volume: ``api.compress_array(a, predict_version=1)`` and the default (version 2)
encode once; then ``--repeat`` rounds decode each (``workers=1``), alternately, and the
best and median times are kept. The ratio of the times is the number to read (the
machine is shared).

    python scripts/bench_predict_version.py brainsmall mri_ch2bet ct_head --repeat 5

Outputs in ``--out`` (default ``results/lossless``): ``predict_version.csv``,
``predict_version.md`` and ``predict_version.png``.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

FIELDS = ["dataset", "shape", "dtype", "ratio_v1", "ratio_v2", "mb_s_v1", "mb_s_v2",
          "time_v2_over_v1_best", "time_v2_over_v1_median", "repeat", "load"]  # fmt: skip


def measure(name: str, repeat: int) -> dict:
    import datasets

    from volpack import api

    a = datasets.load(name)[0]
    blobs = {1: api.compress_array(a, predict_version=1), 2: api.compress_array(a)}
    times: dict[int, list[float]] = {1: [], 2: []}
    for _ in range(repeat):
        for k, blob in blobs.items():
            t0 = time.process_time()
            back = api.decompress_array(blob, workers=1)
            times[k].append(time.process_time() - t0)
            if not np.array_equal(back, a):
                raise AssertionError(f"{name}: version {k} did not round-trip")
    best = {k: min(t) for k, t in times.items()}
    return {
        "dataset": name,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "ratio_v1": round(a.nbytes / len(blobs[1]), 3),
        "ratio_v2": round(a.nbytes / len(blobs[2]), 3),
        "mb_s_v1": round(a.nbytes / 1e6 / best[1], 2),
        "mb_s_v2": round(a.nbytes / 1e6 / best[2], 2),
        "time_v2_over_v1_best": round(best[2] / best[1], 3),
        "time_v2_over_v1_median": round(float(np.median(times[2]) / np.median(times[1])), 3),
        "repeat": repeat,
        "load": f"{os.getloadavg()[0]:.1f}",
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="*", default=["brainsmall", "mri_ch2bet", "ct_head"])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless")
    args = ap.parse_args(argv)
    rows = []
    for name in args.datasets:
        rows.append(measure(name, max(1, args.repeat)))
        print(rows[-1], flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "predict_version.csv", "w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(rows)
    lines = ["| " + " | ".join(FIELDS) + " |", "|" + "---|" * len(FIELDS)]
    lines += ["| " + " | ".join(str(r[k]) for k in FIELDS) + " |" for r in rows]
    (args.out / "predict_version.md").write_text("\n".join(lines) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    x = np.arange(len(rows))
    ax.bar(x - 0.2, [r["ratio_v2"] / r["ratio_v1"] for r in rows], 0.4, label="ratio v2 / v1")
    ax.bar(x + 0.2, [r["time_v2_over_v1_best"] for r in rows], 0.4, label="decode time v2 / v1")
    ax.axhline(1.0, color="k", linewidth=0.5)
    ax.set_xticks(x)
    ax.set_xticklabels([r["dataset"] for r in rows])
    ax.legend()
    ax.set_title("lossless predictive stream: version 2 against version 1")
    fig.tight_layout()
    fig.savefig(args.out / "predict_version.png", dpi=120)
    print(f"wrote {args.out}: predict_version.csv, .md, .png")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
