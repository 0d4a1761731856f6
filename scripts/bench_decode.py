"""Decode speed of the lossless codecs per core, and over two workers, against JPEG-LS
in the same process on the same array.

For each volume and each codec of ``--codecs`` (``default``: the ``lossless`` codec;
``fast``: the ``fast`` codec, MED / 3-D MED prediction and static rANS): the codec
(``api.compress_array``, 64^3 bricks) encodes once; then, best of ``--repeat`` runs,

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
    python scripts/bench_decode.py --all --codecs fast --label fast   # every integer volume

Outputs in ``--out`` (default ``results/lossless``): ``decode_speed.csv`` and
``decode_speed.md`` (rows appended per run label ``--label`` and codec),
``decode_speed.png`` (speed over JPEG-LS's per volume) and ``fast_vs_jpegls.png`` (the
``fast`` codec's ratio and speed, each over JPEG-LS's, per volume).
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

CODECS = {"default": {}, "fast": {"codec": "fast"}}
FIELDS = [
    "label",
    "codec",
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


def measure(name: str, a: np.ndarray, repeat: int, label: str, codec: str) -> dict:
    import imagecodecs as ic

    from volpack import api
    from volpack.format.container import Reader
    from volpack.volume_codec.registry import get_codec

    mb = a.nbytes / 1e6
    blob = api.compress_array(a, **CODECS[codec])
    api.decompress_array(blob, workers=2)  # compiles (or loads) every kernel used
    t1, back = _cpu_best(lambda: api.decompress_array(blob, workers=1), repeat)
    if not np.array_equal(back, a):
        raise AssertionError(f"{name}: volpack did not round-trip")
    w1 = _wall_best(lambda: api.decompress_array(blob, workers=1), repeat)
    w2 = _wall_best(lambda: api.decompress_array(blob, workers=2), repeat)
    if not np.array_equal(api.decompress_array(blob, workers=2), a):
        raise AssertionError(f"{name}: two workers decoded differently")

    # Per tool: the stored brick payloads decoded through the codec alone.
    tools: dict[str, list[float]] = collections.defaultdict(lambda: [0.0, 0.0])
    with Reader(blob) as r:
        c = get_codec(r.header["codec"])
        brick = tuple(r.header["brick"])
        from volpack.volume_codec import bricks

        payloads = [(r.read(e.t, e.node), e.node) for e in r.entries]
    for p, node in payloads:
        sl = bricks.brick_slices(a.shape, brick, node)
        shape = tuple(s.stop - s.start for s in sl)
        t, _ = _cpu_best(lambda p=p, s=shape: c.decode(p, s, a.dtype), repeat)
        tools[c.describe(p)][0] += int(np.prod(shape)) * a.itemsize / 1e6
        tools[c.describe(p)][1] += t

    shift = 1 << (8 * a.itemsize - 1) if a.dtype.kind == "i" else 0
    u = (a.astype(np.int64) + shift).astype(f"u{a.itemsize}")
    enc = [ic.jpegls_encode(s) for s in u]
    tj, _ = _cpu_best(lambda: [ic.jpegls_decode(e) for e in enc], repeat)
    return {
        "label": label,
        "codec": codec,
        "dataset": name,
        "shape": "x".join(map(str, a.shape)),
        "dtype": str(a.dtype),
        "bricks": len(payloads),
        "ratio": round(a.nbytes / len(blob), 3),
        "volpack_mb_s": round(mb / t1, 2),
        "jpegls_ratio": round(a.nbytes / sum(map(len, enc)), 3),
        "jpegls_mb_s": round(mb / tj, 2),
        "vs_jpegls": round(tj / t1, 3),
        "scaling_2_workers": round(w1 / w2, 2),
        "tools": "; ".join(
            f"{k} {m:.1f} MB at {m / t:.1f} MB/s" for k, (m, t) in sorted(tools.items())
        ),
        "load": f"{os.getloadavg()[0]:.1f}",
    }


def write(rows: list[dict], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    path = out / "decode_speed.csv"
    old = []
    if path.exists():
        with path.open() as f:
            old = [{**r, "codec": r.get("codec") or "default"} for r in csv.DictReader(f)]
    keys = {(r["label"], r["codec"], r["dataset"]) for r in rows}
    allrows = [r for r in old if (r["label"], r["codec"], r["dataset"]) not in keys] + rows
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, FIELDS)
        w.writeheader()
        w.writerows(allrows)
    lines = [
        "# Decode speed per core: the lossless codecs against JPEG-LS",
        "",
        "`python scripts/bench_decode.py ...` (see the script): CPU seconds, best of the"
        " runs, in one process; `vs jpegls` = volpack MB/s / JPEG-LS MB/s measured beside it;"
        " `2 workers` = wall time of one worker / two (threads over 64^3 bricks).",
        "",
        "| run | codec | volume | shape dtype | bricks | ratio | MB/s | JPEG-LS ratio"
        " | JPEG-LS MB/s | vs jpegls | 2 workers | load | per tool |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in allrows:
        lines.append(
            f"| {r['label']} | {r['codec']} | {r['dataset']} | {r['shape']} {r['dtype']} | "
            f"{r['bricks']} | "
            f"{r['ratio']} | {r['volpack_mb_s']} | {r['jpegls_ratio']} | {r['jpegls_mb_s']} | "
            f"{r['vs_jpegls']} | {r['scaling_2_workers']} | {r['load']} | {r['tools']} |"
        )
    (out / "decode_speed.md").write_text("\n".join(lines) + "\n")
    plot(allrows, out / "decode_speed.png")
    fast = [r for r in allrows if r["codec"] == "fast"]
    if fast:
        plot_fast(fast, out / "fast_vs_jpegls.png")


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [{**r, "label": f"{r['label']} {r['codec']}"} for r in rows]
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
    ax.set_title("Lossless codecs: decode CPU time against JPEG-LS (same process)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_fast(rows: list[dict], path: Path) -> None:
    """The fast codec per volume: its ratio over JPEG-LS's and its decode speed over
    JPEG-LS's (the last run of each volume)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    last = {r["dataset"]: r for r in rows}
    fig, ax = plt.subplots(figsize=(7, 5))
    for d, r in last.items():
        x = float(r["ratio"]) / float(r["jpegls_ratio"])
        y = float(r["vs_jpegls"])
        ax.scatter(x, y, color="C1")
        ax.annotate(d, (x, y), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.axvline(1.0, color="k", lw=0.6)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.set_xlabel("ratio / JPEG-LS ratio")
    ax.set_ylabel("decode MB/s per core / JPEG-LS's")
    ax.set_title("fast codec against JPEG-LS (CharLS per slice), same process")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="*", default=["ct_head"])
    ap.add_argument("--all", action="store_true", help="every integer volume in the cache")
    ap.add_argument("--codecs", default="default", help=f"comma-separated, of {sorted(CODECS)}")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--label", default=datetime.date.today().isoformat())
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless")
    args = ap.parse_args(argv)
    import datasets

    codecs = args.codecs.split(",")
    if any(c not in CODECS for c in codecs):
        ap.error(f"expected codecs among {sorted(CODECS)}, found {args.codecs!r}")
    rows = []
    for name in datasets.names(kinds=("int",)) if args.all else args.datasets:
        a, _, _ = datasets.load(name)
        a = np.ascontiguousarray(a)
        for codec in codecs:
            row = measure(name, a, args.repeat, args.label, codec)
            print(row, flush=True)
            rows.append(row)
    write(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
