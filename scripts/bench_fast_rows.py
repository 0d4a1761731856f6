"""The fast codec's row kinds against its streams of before (``rows=False``): ratio and
decode CPU time in one process, on the same bricks, alternating.

For each volume: the fast codec (64^3 bricks) encodes twice, with the row kinds (the
default) and without; every brick payload of each is decoded into its place in one
output volume (``decode_into``, as the reader does, without the container and thread
set-up), both sets alternating, best of ``--repeat``, CPU seconds. Both decodes run the
same decoder on the same machine state, so the ratio of their times holds better than
two runs of ``bench_decode.py`` minutes apart on a busy machine.

    python scripts/bench_fast_rows.py liver_labels frog_labels atlas_aal
    python scripts/bench_fast_rows.py --all       # every integer volume in the cache

Outputs in ``--out`` (default ``results/lossless``): ``fast_rows.csv``, ``fast_rows.md``
(rows replaced per volume) and ``fast_rows.png`` (decode speed-up against the change of
ratio, per volume).
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

FIELDS = [
    "dataset",
    "shape",
    "bricks",
    "ratio_before",
    "ratio_after",
    "ms_before",
    "ms_after",
    "mb_s_before",
    "mb_s_after",
    "speedup",
    "rows_bricks",
    "load",
]


def measure(name: str, a: np.ndarray, repeat: int) -> dict:
    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec import bricks
    from volpack.volume_codec.registry import get_codec

    sets = {}
    for label, options in (("before", {"rows": False}), ("after", {})):
        blob = api.compress_array(a, codec="fast", **options)
        with Reader(blob) as r:
            c = get_codec(r.header["codec"])
            shape = tuple(r.header["brick"])
            items = [
                (r.read(e.t, e.node), bricks.brick_slices(a.shape, shape, e.node))
                for e in r.entries
            ]
        sets[label] = (len(blob), c, items)
    out = np.empty_like(a)
    best = {"before": float("inf"), "after": float("inf")}
    for _ in range(repeat):
        for label, (_, c, items) in sets.items():
            t = time.process_time()
            for payload, sl in items:
                c.decode_into(payload, out[sl])
            best[label] = min(best[label], time.process_time() - t)
            if not np.array_equal(out, a):
                raise AssertionError(f"{name}: the {label} stream did not round-trip")
    mb = a.nbytes / 1e6
    _, c, items = sets["after"]
    return {
        "dataset": name,
        "shape": "x".join(map(str, a.shape)) + f" {a.dtype}",
        "bricks": len(items),
        "ratio_before": round(a.nbytes / sets["before"][0], 3),
        "ratio_after": round(a.nbytes / sets["after"][0], 3),
        "ms_before": round(best["before"] * 1e3, 2),
        "ms_after": round(best["after"] * 1e3, 2),
        "mb_s_before": round(mb / best["before"], 1),
        "mb_s_after": round(mb / best["after"], 1),
        "speedup": round(best["before"] / best["after"], 3),
        "rows_bricks": sum("+rows" in c.describe(p) for p, _ in items),
        "load": f"{os.getloadavg()[0]:.1f}",
    }


def write(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "fast_rows.csv"
    old = list(csv.DictReader(path.open())) if path.exists() else []
    names = {r["dataset"] for r in rows}
    allrows = [r for r in old if r["dataset"] not in names] + rows
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(allrows)
    lines = [
        "# The fast codec's row kinds against its streams of before (rows=False)",
        "",
        "`python scripts/bench_fast_rows.py ...`: one process, the same bricks decoded into"
        " one volume, both streams alternating, best of the runs, CPU seconds.",
        "",
        "| volume | shape dtype | bricks | ratio before | ratio after | ms before | ms after"
        " | MB/s before | MB/s after | speed-up | bricks with rows | load |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in allrows:
        lines.append("| " + " | ".join(str(r[k]) for k in FIELDS) + " |")
    (out / "fast_rows.md").write_text("\n".join(lines) + "\n")
    plot(allrows, out / "fast_rows.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 5))
    for r in rows:
        x = float(r["ratio_after"]) / float(r["ratio_before"])
        y = float(r["speedup"])
        ax.scatter(x, y, color="C0")
        ax.annotate(r["dataset"], (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axhline(1.0, color="k", lw=0.6)
    ax.axvline(1.0, color="k", lw=0.6)
    ax.set_xlabel("ratio with the row kinds / ratio without")
    ax.set_ylabel("decode speed with the row kinds / without (same process)")
    ax.set_title("fast codec: the row kinds (rows) against rows=False")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="*", default=["liver_labels"])
    ap.add_argument("--all", action="store_true", help="every integer volume in the cache")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless")
    args = ap.parse_args(argv)
    import datasets

    rows = []
    for name in datasets.names(kinds=("int",)) if args.all else args.datasets:
        a = np.ascontiguousarray(datasets.load(name)[0])
        row = measure(name, a, args.repeat)
        print(row, flush=True)
        rows.append(row)
    write(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
