"""Decode speed of the default lossless codec per core, and over two workers, against
JPEG-LS in the same process on the same array.

For each volume: the default codec (``api.compress_array``, 64^3 bricks) encodes once;
then, best of ``--repeat`` runs,

* ``volpack`` decode MB/s per core: CPU seconds of the process (``time.process_time``)
  for ``api.decompress_array(workers=1)``; MB = 1e6 bytes of raw voxels;
* each tool's share: every brick payload decoded on its own by the codec, CPU seconds
  summed by the tool ``volpack info`` names (predict, labels, wavelet, ...);
* ``jpegls`` decode MB/s per core: CharLS through imagecodecs, per z slice, CPU seconds
  (signed volumes shifted to unsigned first, outside the timing);
* ``scaling``: wall seconds of ``workers=1`` over ``workers=2`` (threads over bricks;
  the decoded array is checked equal for both).

CPU seconds rather than wall seconds because the machine is shared; the ratio to
JPEG-LS is the number to read. For a before/after in one sitting, run it again with
``PYTHONPATH`` set to another checkout (e.g. the main branch) and another ``--label``.

    python scripts/bench_decode.py ct_head mri_ch2bet --repeat 5

Outputs in ``--out`` (default ``results/lossless``): ``decode_speed.csv`` and
``decode_speed.md`` (rows appended per run label ``--label``), ``decode_speed.png``.
"""

from __future__ import annotations

import argparse
import collections
import csv
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

FIELDS = [
    "label",
    "dataset",
    "shape",
    "dtype",
    "bricks",
    "ratio",
    "volpack_mb_s",
    "jpegls_ratio",
    "jpegls_mb_s",
    "vs_jpegls",
    "scaling_2_workers",
    "tools",
    "load",
]


def _cpu_best(fn, repeat: int):
    best, out = float("inf"), None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


def _wall_best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def measure(name: str, a: np.ndarray, repeat: int, label: str) -> dict:
    import imagecodecs as ic

    from volpack import api
    from volpack.volume_codec.lossless import LosslessCodec, describe

    mb = a.nbytes / 1e6
    blob = api.compress_array(a)
    api.decompress_array(blob, workers=2)  # compiles (or loads) every kernel used
    t1, back = _cpu_best(lambda: api.decompress_array(blob, workers=1), repeat)
    if not np.array_equal(back, a):
        raise AssertionError(f"{name}: volpack did not round-trip")
    w1 = _wall_best(lambda: api.decompress_array(blob, workers=1), repeat)
    w2 = _wall_best(lambda: api.decompress_array(blob, workers=2), repeat)
    if not np.array_equal(api.decompress_array(blob, workers=2), a):
        raise AssertionError(f"{name}: two workers decoded differently")

    # Per tool: the same bricks through the codec alone.
    codec, b = LosslessCodec(), 64
    tools: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    nbricks = 0
    for z in range(0, a.shape[0], b):
        for y in range(0, a.shape[1], b):
            for x in range(0, a.shape[2], b):
                brick = np.ascontiguousarray(a[z : z + b, y : y + b, x : x + b])
                p = codec.encode(brick)
                t, _ = _cpu_best(
                    lambda p=p, s=brick.shape, d=brick.dtype: codec.decode(p, s, d), repeat
                )
                tools[describe(p)][0] += brick.nbytes / 1e6
                tools[describe(p)][1] += t
                nbricks += 1

    shift = 1 << (8 * a.itemsize - 1) if a.dtype.kind == "i" else 0
    u = (a.astype(np.int64) + shift).astype(f"u{a.itemsize}")
    enc = [ic.jpegls_encode(s) for s in u]
    tj, _ = _cpu_best(lambda: [ic.jpegls_decode(e) for e in enc], repeat)
    return {
        "label": label,
        "dataset": name,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "bricks": nbricks,
        "ratio": round(a.nbytes / len(blob), 3),
        "volpack_mb_s": round(mb / t1, 2),
        "jpegls_ratio": round(a.nbytes / sum(map(len, enc)), 3),
        "jpegls_mb_s": round(mb / tj, 2),
        "vs_jpegls": round(tj / t1, 3),
        "scaling_2_workers": round(w1 / w2, 2),
        "tools": "; ".join(f"{k} {m:.1f} MB at {m / t:.1f} MB/s" for k, (m, t) in tools.items()),
        "load": f"{os.getloadavg()[0]:.1f}",
    }


def write(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "decode_speed.csv"
    old = []
    if path.exists():
        with path.open() as f:
            old = [r for r in csv.DictReader(f)]
    keys = {(r["label"], r["dataset"]) for r in rows}
    allrows = [r for r in old if (r["label"], r["dataset"]) not in keys] + rows
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(allrows)
    lines = [
        "# Decode speed per core: the default lossless codec against JPEG-LS",
        "",
        "`python scripts/bench_decode.py ...` (see the script): CPU seconds, best of the"
        " runs, in one process; `vs jpegls` = volpack MB/s / JPEG-LS MB/s measured beside it;"
        " `2 workers` = wall time of one worker / two (threads over 64^3 bricks).",
        "",
        "| run | volume | shape dtype | bricks | ratio | MB/s | JPEG-LS ratio | JPEG-LS MB/s"
        " | vs jpegls | 2 workers | load | per tool |",
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in allrows:
        lines.append(
            f"| {r['label']} | {r['dataset']} | {r['shape']} {r['dtype']} | {r['bricks']} | "
            f"{r['ratio']} | {r['volpack_mb_s']} | {r['jpegls_ratio']} | {r['jpegls_mb_s']} | "
            f"{r['vs_jpegls']} | {r['scaling_2_workers']} | {r['load']} | {r['tools']} |"
        )
    (out / "decode_speed.md").write_text("\n".join(lines) + "\n")
    plot(allrows, out / "decode_speed.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(dict.fromkeys(r["label"] for r in rows))
    dsets = list(dict.fromkeys(r["dataset"] for r in rows))
    fig, ax = plt.subplots(figsize=(max(6, 1.2 * len(dsets) + 2), 4))
    width = 0.8 / max(len(labels), 1)
    for j, lab in enumerate(labels):
        xs, ys = [], []
        for i, d in enumerate(dsets):
            for r in rows:
                if r["label"] == lab and r["dataset"] == d:
                    xs.append(i + (j - len(labels) / 2 + 0.5) * width)
                    ys.append(float(r["vs_jpegls"]))
        ax.bar(xs, ys, width, label=lab, edgecolor="k", linewidth=0.3)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set_xticks(range(len(dsets)))
    ax.set_xticklabels(dsets)
    ax.set_ylabel("decode speed per core / JPEG-LS's")
    ax.set_title("Default lossless codec: decode CPU time against JPEG-LS (same process)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="*", default=["ct_head"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default=datetime.date.today().isoformat())
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless")
    args = ap.parse_args(argv)
    import datasets

    rows = []
    for name in args.datasets:
        a, _, _ = datasets.load(name)
        a = np.ascontiguousarray(a)
        row = measure(name, a, args.repeat, args.label)
        print(row, flush=True)
        rows.append(row)
    write(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
