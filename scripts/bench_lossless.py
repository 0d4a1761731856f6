"""Lossless benchmark: volpack against peer codecs on a corpus of real volumes.

Every method runs in this process on the same array. For each one we report

* ratio: raw bytes of the volume in its own dtype (2 bytes a voxel for int16 CT, 4 for
  float32) divided by the compressed bytes, whatever the codec was fed internally;
* encode / decode MB/s: MB = 1e6 bytes of raw voxels, best of ``--repeat`` runs;
* exact: the decoded array equals the original bit for bit (floats compared as their bit
  patterns, so NaN, -0.0 and denormals count). A row that does not round-trip raises.

The corpus is every dataset of ``scripts/datasets.py`` in the cache (integer and float),
each named with its package in the table. Peers, as their authors run them:

* integers: zstd-19 (byte-shuffled for 16 bits), blosc2 (zstd 9 + bitshuffle), zfp
  reversible (int32 copy), and per z slice via imagecodecs: JPEG-LS (CharLS), JPEG 2000
  (OpenJPEG, reversible 5/3), HTJ2K (OpenJPH, reversible) and JPEG-XL lossless at efforts
  3, 7 (its default), 9 and 10 (libjxl's highest: 11 codes as 10 through imagecodecs);
  the table reports JPEG-XL's best effort. JPEG-LS, HTJ2K and
  JPEG-XL take unsigned samples, so signed volumes are shifted by ``2**(bits-1)`` (a
  sign-bit flip) and back.
* floats: zstd-19 byte-shuffled, blosc2, zfp reversible, fpzip (``precision=0``,
  lossless) and pcodec (``standalone.simple_compress``, default level).

volpack rows: ``volpack`` (the default: the ``lossless`` codec, per brick the wavelet,
3-D prediction, labels or floats split; 1 and 2 workers), ``volpack-max``
(``effort='max'``: on integers the predictive stream also with the local fit, on floats
the fitted predictor also with a box fit), ``volpack-wavelet`` (the
wavelet codec alone, the previous default), ``volpack-wavelet-huffman`` (its fast
coder), ``volpack-arith2`` and ``volpack-wavelet-arith2`` (both with the ``arith2`` coder); floats: ``volpack`` and ``volpack-zstd`` (byte-shuffled zstd, the previous float
path). ``--grid`` adds every wavelet x coder of the wavelet codec.

    python scripts/fetch_data.py                       # once
    python scripts/bench_lossless.py --quick           # 128^3 centre crops, fast
    python scripts/bench_lossless.py --datasets ct_head mri_ch2bet

Outputs in ``--out`` (default ``results/lossless``): ``lossless.csv`` (every row, written
after each dataset), ``run.json``, ``table.md`` (ratio per volume: volpack, the best
peer and each peer; every method on ``--speed-dataset`` with its speeds),
``ratio.png`` (ratio per volume per codec, relative to the best peer) and
``ratio_vs_decode.png``. ``--replot`` redraws charts and table from the CSV.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

from volpack import peers as peer_codecs  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FIELDS = [
    "dataset",
    "source",
    "shape",
    "dtype",
    "method",
    "ratio",
    "encode_mb_s",
    "decode_mb_s",
    "workers",
    "repeat",
    "exact",
    "raw_bytes",
    "compressed_bytes",
]
JPEGXL_EFFORTS = (3, 7, 9, 10)  # 10 is the highest libjxl takes (11 codes as 10)
# volpack rows beyond the default: (row name, api options). Integer and float volumes.
VOLPACK_ROWS_INT = (
    ("volpack-max", {"effort": "max"}),  # version 10: the local fit where it is shorter
    ("volpack-wavelet", {"codec": "wavelet"}),  # the wavelet codec alone (the old default)
    ("volpack-wavelet-huffman", {"codec": "wavelet", "coder": "huffman"}),
    ("volpack-arith2", {"coder": "arith2"}),  # the default with the multi-symbol rANS coder
    ("volpack-wavelet-arith2", {"codec": "wavelet", "coder": "arith2"}),
)
VOLPACK_ROWS_FLOAT = (
    ("volpack-max", {"effort": "max"}),  # version 10: the box fit where it is shorter
    ("volpack-zstd", {"codec": "zstd"}),
)
ALSO_VS_PEER = ("volpack-max",)  # rows the table also sets against the best peer
GRID_WAVELETS = ("53", "26", "haar", "97m")
GRID_CODERS = ("arith", "arith2", "huffman", "rle")
SPEED_DATASET = "ct_head"


@dataclass
class Method:
    name: str
    workers: int
    encode: Callable[[np.ndarray], object]  # -> bytes, or list of bytes (one per slice)
    decode: Callable[[object], np.ndarray]
    note: str = ""
    encode_repeat: int | None = None  # cap on encode runs (slow efforts)
    options: dict = field(default_factory=dict)


def warn(message: str) -> None:
    print(f"warning: {message}", file=sys.stderr, flush=True)


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal dtype, shape and bytes (floats compared as bit patterns)."""
    b = np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    return np.array_equal(a.view(f"u{a.itemsize}"), np.ascontiguousarray(b).view(f"u{a.itemsize}"))


# ---------------------------------------------------------------------------------------
# Peers


def peer_methods(dtype: np.dtype, shape) -> list[Method]:
    """The peers of :mod:`volpack.peers` (the settings ``volpack compare --peers`` runs),
    JPEG-XL at every effort of ``JPEGXL_EFFORTS`` and JPEG-LS on one and two threads."""
    found, skipped = peer_codecs.lossless(
        dtype, shape, jpegxl_efforts=JPEGXL_EFFORTS, workers=(1, 2)
    )
    for line in skipped:
        warn(f"skipping {line}")
    return [
        Method(p.name, p.workers, p.encode, p.decode, p.note, encode_repeat=1 if p.slow else None)
        for p in found
    ]


# ---------------------------------------------------------------------------------------
# volpack


def volpack_methods(
    dtype: np.dtype, shape, brick: int | None, grid: bool, workers=(1, 2)
) -> list[Method]:
    try:
        from volpack import api
    except Exception as exc:
        warn(f"skipping volpack rows: cannot import volpack.api ({exc!r})")
        return []
    base = {} if brick is None else {"brick": brick}
    rows = [("volpack", {})]
    rows += list(VOLPACK_ROWS_FLOAT if dtype.kind == "f" else VOLPACK_ROWS_INT)
    if grid and dtype.kind != "f":
        rows += [
            (f"volpack-{w}-{c}", {"codec": "wavelet", "wavelet": w, "coder": c})
            for w in GRID_WAVELETS
            for c in GRID_CODERS
        ]
    out = []
    for name, opts in rows:
        opts = {**base, **opts}
        for w in workers if name == "volpack" else (1,):
            out.append(
                Method(
                    name,
                    w,
                    lambda a, o=opts, w=w: api.compress_array(a, workers=w, **o),
                    lambda b, w=w: api.decompress_array(b, workers=w),
                    f"api.compress_array({', '.join(f'{k}={v!r}' for k, v in opts.items())})",
                    options=opts,
                )
            )
    return out


def warm_up(methods: list[Method], dtype: np.dtype) -> list[Method]:
    """Compile every volpack kernel before anything is timed; drop rows that fail."""
    rng = np.random.default_rng(0)
    z, y, x = np.mgrid[:24, :40, :36]
    a = ((z * 3 + y * 2 + x) % 200 + rng.integers(-3, 4, z.shape)).astype(dtype)
    a[:4] = 0
    kept = []
    for m in methods:
        if not m.name.startswith("volpack"):
            kept.append(m)
            continue
        try:
            back = m.decode(m.encode(a))
        except Exception as exc:
            warn(f"skipping {m.name}: warm-up failed ({exc!r})")
            continue
        if not same_bits(a, back):
            raise AssertionError(f"{m.name}: warm-up round trip is not exact")
        kept.append(m)
    return kept


# ---------------------------------------------------------------------------------------
# Running


def measure(method: Method, a: np.ndarray, repeat: int) -> dict:
    raw = a.nbytes
    enc_t, dec_t = [], []
    blob = back = None
    for _ in range(min(repeat, method.encode_repeat or repeat)):
        t0 = time.perf_counter()
        blob = method.encode(a)
        enc_t.append(time.perf_counter() - t0)
    for _ in range(repeat):
        t0 = time.perf_counter()
        back = method.decode(blob)
        dec_t.append(time.perf_counter() - t0)
    if not same_bits(a, back):
        back = np.asarray(back)
        raise AssertionError(
            f"{method.name} (workers {method.workers}) did not round-trip exactly: "
            f"got {back.dtype} {back.shape}, expected {a.dtype} {a.shape}"
        )
    size = peer_codecs.nbytes(blob)
    return {
        "method": method.name,
        "workers": method.workers,
        "repeat": repeat,
        "ratio": raw / size,
        "encode_mb_s": raw / 1e6 / min(enc_t),
        "decode_mb_s": raw / 1e6 / min(dec_t),
        "exact": True,
        "raw_bytes": raw,
        "compressed_bytes": size,
    }


def center_crop(a: np.ndarray, n: int = 128) -> np.ndarray:
    sl = tuple(slice(max(0, (s - n) // 2), max(0, (s - n) // 2) + min(s, n)) for s in a.shape)
    return np.ascontiguousarray(a[sl])


def source_of(name: str) -> str:
    ds = datasets.DATASETS[name]
    return f"{ds.source}:{ds.package}"


def run(names, args, checkpoint=None):
    rows, notes, skipped = [], {}, []
    for name in names:
        a, _, desc = datasets.load(name)
        if args.quick:
            a = center_crop(a)
        shape = "x".join(map(str, a.shape))
        print(f"\n== {name}: {shape} {a.dtype} ({a.nbytes / 1e6:.2f} MB) {desc}", flush=True)
        t_ds = time.perf_counter()
        methods = []
        if not args.no_volpack:
            methods += volpack_methods(a.dtype, a.shape, args.brick, args.grid, args.workers)
        if not args.no_peers:
            methods += peer_methods(a.dtype, a.shape)
        if args.methods:
            methods = [m for m in methods if m.name in args.methods]
        for m in warm_up(methods, a.dtype):
            try:
                result = measure(m, a, args.repeat)
            except AssertionError:
                raise
            except Exception as exc:
                warn(f"{name}: {m.name} (workers {m.workers}) failed, row skipped ({exc!r})")
                skipped.append(f"{name}: {m.name} (workers {m.workers}): {exc!r}")
                continue
            row = {
                "dataset": name,
                "source": source_of(name),
                "shape": shape,
                "dtype": str(a.dtype),
                **result,
            }
            rows.append(row)
            if m.note:
                notes[m.name] = m.note
            print(
                f"  {m.name:24s} w{m.workers}  ratio {row['ratio']:7.3f}  "
                f"enc {row['encode_mb_s']:8.1f} MB/s  dec {row['decode_mb_s']:8.1f} MB/s",
                flush=True,
            )
        print(f"  ({name} took {time.perf_counter() - t_ds:.0f} s)", flush=True)
        if checkpoint is not None:
            checkpoint(rows)
    return rows, notes, skipped


# ---------------------------------------------------------------------------------------
# Outputs


def merge(old: list[dict], new: list[dict]) -> list[dict]:
    """``new`` rows replace the ``old`` ones of the same (dataset, method, workers);
    rows stay grouped by dataset in first-seen order."""
    key = lambda r: (r["dataset"], r["method"], int(r["workers"]))  # noqa: E731
    fresh = {key(r) for r in new}
    rows = [r for r in old if key(r) not in fresh] + new
    order = list(dict.fromkeys(r["dataset"] for r in rows))
    return sorted(rows, key=lambda r: order.index(r["dataset"]))


def write_csv(rows, path: Path) -> None:
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.4f}" if isinstance(r[k], float) else r[k]) for k in FIELDS})


def read_csv(path: Path) -> list[dict]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for r in rows:
        for k in ("ratio", "encode_mb_s", "decode_mb_s"):
            r[k] = float(r[k])
        for k in ("workers", "raw_bytes", "compressed_bytes", "repeat"):
            r[k] = int(r[k])
    return rows


def machine_info() -> dict[str, str]:
    info = {
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "nproc": str(os.cpu_count()),
        "cpu": _cpu_model(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "load average at start": " ".join(f"{x:.2f}" for x in os.getloadavg()),
    }
    for mod in (
        "numba",
        "volpack",
        "zstandard",
        "blosc2",
        "zfpy",
        "imagecodecs",
        "fpzip",
        "pcodec",
    ):
        try:
            info[mod] = getattr(__import__(mod), "__version__", "?")
        except Exception:
            info[mod] = "missing"
    return info


def _cpu_model() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "?"


def _is_volpack(method: str) -> bool:
    return method.startswith("volpack")


def _family(method: str) -> str:
    """A peer's family: the JPEG-XL efforts are one peer (its best effort counts); zstd
    is one column, byte-shuffled or not."""
    if method.startswith("jpegxl-"):
        return "jpegxl"
    return "zstd-19" if method.startswith("zstd-19") else method


def _by_dataset(rows) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        out.setdefault(r["dataset"], []).append(r)
    return out


def _one(rows, method: str, workers: int = 1) -> dict | None:
    for r in rows:
        if r["method"] == method and r["workers"] == workers:
            return r
    return None


def best_peer(rows) -> dict | None:
    peers = [r for r in rows if not _is_volpack(r["method"]) and r["workers"] == 1]
    return max(peers, key=lambda r: r["ratio"], default=None)


def _peer_columns(rows) -> list[str]:
    """Peer families in first-seen order (JPEG-XL once)."""
    return list(dict.fromkeys(_family(r["method"]) for r in rows if not _is_volpack(r["method"])))


def _family_best(rows, family: str) -> dict | None:
    cand = [r for r in rows if _family(r["method"]) == family and r["workers"] == 1]
    return max(cand, key=lambda r: r["ratio"], default=None)


def machine_line(info: dict[str, str]) -> str:
    libs = ", ".join(
        f"{k} {info.get(k, '?')}"
        for k in ("volpack", "zstandard", "blosc2", "zfpy", "imagecodecs", "fpzip", "pcodec")
    )
    return (
        f"Machine: {info['nproc']} cores ({info['cpu']}), Python {info['python']}, "
        f"numpy {info['numpy']}, numba {info['numba']}; run {info['date']} "
        f"(load average at start {info['load average at start']}"
        + (f", at end {info['load average at end']}" if "load average at end" in info else "")
        + f"). Libraries: {libs}."
    )


def write_table(rows, notes, skipped, path: Path, run: dict, info: dict[str, str]) -> None:
    by_ds = _by_dataset(rows)
    vp_cols = list(dict.fromkeys(r["method"] for r in rows if _is_volpack(r["method"])))
    vp_cols.sort(key=lambda m: m != "volpack")  # the default first
    peers = _peer_columns(rows)
    lines = [
        "# Lossless benchmark",
        "",
        machine_line(info),
        "",
        f"Ratio = raw bytes in the volume's own dtype / compressed bytes. MB/s counts raw "
        f"voxel bytes (1 MB = 10⁶ B), best of {run['repeat']} runs"
        + (", on 128³ centre crops" if run["quick"] else "")
        + ". Every row round-trips bit for bit. Speeds are from a shared 2-core machine: "
        "compare rows within one run. All rows are in `lossless.csv`.",
        "",
        "## Ratio per volume",
        "",
        "`vs best peer` = volpack's ratio / the best peer's (goal ≥ 1.10, floor 1.00 on "
        "8/16-bit volumes). JPEG-XL shows its best effort (in brackets). Best in bold.",
        "",
    ]
    cols = vp_cols + peers
    also = [m for m in ALSO_VS_PEER if m in vp_cols]
    lines.append(
        "| volume (source) | shape dtype | " + " | ".join(cols) + " | best peer | vs best peer |"
        + "".join(f" {m} vs best peer |" for m in also)
    )
    lines.append("|---|---|" + "---:|" * len(cols) + "---|---:|" + "---:|" * len(also))
    for ds, rs in by_ds.items():
        vals = [(_one(rs, m) or {}).get("ratio") for m in vp_cols]
        fams = [_family_best(rs, f) for f in peers]
        vals += [None if r is None else r["ratio"] for r in fams]
        shown = _bold_best(vals)
        for i, r in enumerate(fams):
            if r is not None and r["method"].startswith("jpegxl-"):
                shown[len(vp_cols) + i] += f" ({r['method'][7:]})"
        bp = best_peer(rs)
        vp = _one(rs, "volpack")
        rel = "—" if bp is None or vp is None else f"{vp['ratio'] / bp['ratio']:.3f}"
        for m in also:
            r = _one(rs, m)
            rel += " | " + ("—" if bp is None or r is None else f"{r['ratio'] / bp['ratio']:.3f}")
        lines.append(
            f"| {ds} ({rs[0]['source']}) | {rs[0]['shape']} {rs[0]['dtype']} | "
            + " | ".join(shown)
            + f" | {bp['method'] if bp else '—'} | {rel} |"
        )
    lines.append("")
    ds = run.get("speed_dataset", SPEED_DATASET)
    if ds not in by_ds and by_ds:
        ds = next(iter(by_ds))
    if ds in by_ds:
        rs = by_ds[ds]
        r0 = rs[0]
        lines += [
            f"## Every method on {ds} ({r0['shape']} {r0['dtype']}, "
            f"{r0['raw_bytes'] / 1e6:.2f} MB)",
            "",
            "| method | workers | ratio | encode MB/s | decode MB/s |",
            "|---|---:|---:|---:|---:|",
        ]
        for r in sorted(rs, key=lambda r: (-r["ratio"], r["method"], r["workers"])):
            lines.append(
                f"| {r['method']} | {r['workers']} | {r['ratio']:.3f} | "
                f"{r['encode_mb_s']:.1f} | {r['decode_mb_s']:.1f} |"
            )
        lines.append("")
    if skipped:
        lines += ["Skipped rows (the codec raised):", ""] + [f"- {x}" for x in skipped] + [""]
    if notes:
        lines += ["Notes:", ""] + [f"- {k}: {v}" for k, v in sorted(notes.items())] + [""]
    lines.append(f"<!-- args: {json.dumps(run)} -->")
    path.write_text("\n".join(lines) + "\n")


def _bold_best(values: list[float | None], fmt: str = "{:.3f}") -> list[str]:
    shown = [None if v is None else fmt.format(v) for v in values]
    best = max((float(x) for x in shown if x is not None), default=None)
    return ["—" if x is None else (f"**{x}**" if float(x) == best else x) for x in shown]


_COLORS = {
    "volpack": "#c0392b",
    "volpack-wavelet": "#e67e22",
    "volpack-wavelet-huffman": "#f0b27a",
    "volpack-zstd": "#f5b7b1",
    "zstd-19": "#6baed6",
    "zstd-19+shuffle": "#6baed6",
    "blosc2-zstd9+bitshuffle": "#31a354",
    "zfp-rev": "#737373",
    "jpegls": "#8c564b",
    "jpeg2k": "#fdd0a2",
    "htj2k": "#fdae6b",
    "jpegxl": "#9467bd",
    "fpzip": "#17becf",
    "pcodec": "#bcbd22",
}


def plot(rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by_ds = _by_dataset(rows)
    dsets = list(by_ds)
    ones = [r for r in rows if r["workers"] == 1]
    names = list(dict.fromkeys(_family(r["method"]) for r in ones))

    # ratio.png: per volume, each codec's ratio over the best peer's (1 = the best peer).
    fig, ax = plt.subplots(figsize=(max(8, 0.75 * len(dsets) + 3), 5.2))
    width = 0.8 / max(len(names), 1)
    for j, m in enumerate(names):
        xs, ys = [], []
        for i, d in enumerate(dsets):
            rs = [r for r in by_ds[d] if r["workers"] == 1]
            bp = best_peer(rs)
            r = _family_best(rs, m)
            if r is not None and bp is not None:
                xs.append(i + (j - len(names) / 2 + 0.5) * width)
                ys.append(r["ratio"] / bp["ratio"])
        ax.bar(xs, ys, width, label=m, color=_COLORS.get(m, None), edgecolor="k", linewidth=0.2)
    ax.axhline(1.0, color="k", lw=0.6)
    ax.axhline(1.1, color="k", lw=0.6, ls=":")
    labels = []
    for d in dsets:
        bp = best_peer([r for r in by_ds[d] if r["workers"] == 1])
        labels.append(f"{d}\n{by_ds[d][0]['dtype']}, best {bp['ratio']:.2f}" if bp else d)
    ax.set_xticks(range(len(dsets)))
    ax.set_xticklabels(labels, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("ratio / best peer's ratio")
    ax.set_ylim(0, 1.6)
    ax.legend(fontsize=7, ncol=4, loc="upper right")
    ax.grid(axis="y", alpha=0.3)
    ax.set_title("Lossless ratio per volume, relative to the best peer (dotted: 1.1x goal)")
    fig.tight_layout()
    fig.savefig(out / "ratio.png", dpi=110)
    plt.close(fig)

    # ratio_vs_decode.png: per volume, ratio against decode MB/s (1 worker).
    n = len(dsets)
    cols = min(4, n)
    nrows = (n + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 3.4 * nrows), squeeze=False)
    for ax, d in zip(axes.flat, dsets):
        for r in by_ds[d]:
            if r["workers"] != 1:
                continue
            fam = _family(r["method"])
            ax.scatter(
                r["decode_mb_s"],
                r["ratio"],
                s=30 if _is_volpack(r["method"]) else 18,
                color=_COLORS.get(fam, "#999999"),
                edgecolor="k",
                linewidth=0.3,
                zorder=3,
            )
            ax.annotate(r["method"], (r["decode_mb_s"], r["ratio"]), fontsize=5,
                        xytext=(2, 2), textcoords="offset points")  # fmt: skip
        ax.set_xscale("log")
        ax.set_title(f"{d} ({by_ds[d][0]['shape']} {by_ds[d][0]['dtype']})", fontsize=8)
        ax.set_xlabel("decode MB/s, 1 core (log)", fontsize=7)
        ax.set_ylabel("ratio", fontsize=7)
        ax.tick_params(labelsize=6)
        ax.grid(alpha=0.3, which="both")
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.suptitle("Lossless: ratio vs decode speed (1 worker)", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "ratio_vs_decode.png", dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("datasets", nargs="*", metavar="NAME", help="volumes (default: all)")
    parser.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    parser.add_argument("--quick", action="store_true", help="crop each volume to 128^3 centre")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "lossless")
    parser.add_argument("--brick", type=int, default=None, help="volpack brick size")
    parser.add_argument("--grid", action="store_true", help="also every wavelet x coder")
    parser.add_argument("--methods", nargs="+", help="run only these method names")
    parser.add_argument("--no-volpack", action="store_true", help="peers only")
    parser.add_argument("--no-peers", action="store_true", help="volpack only")
    parser.add_argument(
        "--workers", type=int, nargs="+", default=[1, 2],
        help="worker counts of the default volpack row (default 1 2; 1 on a shared machine)",
    )
    parser.add_argument("--speed-dataset", default=SPEED_DATASET)
    parser.add_argument("--replot", action="store_true", help="redraw from OUT/lossless.csv")
    parser.add_argument(
        "--keep",
        action="store_true",
        help="keep the rows of OUT/lossless.csv that this run does not measure again "
        "(e.g. peers measured once, volpack rerun with --no-peers)",
    )
    args = parser.parse_args(argv)

    if args.replot:
        rows = read_csv(args.out / "lossless.csv")
        plot(rows, args.out)
        meta = json.loads((args.out / "run.json").read_text())
        write_table(
            rows, meta["notes"], meta["skipped"], args.out / "table.md", meta["run"], meta["info"]
        )
        return 0

    names = args.datasets or datasets.names(kinds=None)
    if not names:
        parser.error("no dataset fetched: run scripts/fetch_data.py first")
    missing = [n for n in names if n not in datasets.DATASETS]
    if missing:
        parser.error(f"unknown dataset(s) {', '.join(missing)}")
    args.repeat = max(1, args.repeat)
    info = machine_info()
    args.out.mkdir(parents=True, exist_ok=True)
    old, old_meta = [], {"notes": {}, "skipped": []}
    if args.keep and (args.out / "lossless.csv").is_file():
        old = read_csv(args.out / "lossless.csv")
        if (args.out / "run.json").is_file():
            old_meta = json.loads((args.out / "run.json").read_text())
    t0 = time.perf_counter()
    rows, notes, skipped = run(
        names, args, checkpoint=lambda rows: write_csv(merge(old, rows), args.out / "lossless.csv")
    )
    rows = merge(old, rows)
    notes = {**old_meta["notes"], **notes}
    skipped = old_meta["skipped"] + skipped
    if not rows:
        print("nothing measured", file=sys.stderr)
        return 1
    info["load average at end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    run_meta = {
        "repeat": args.repeat,
        "quick": args.quick,
        "brick": args.brick,
        "grid": args.grid,
        "speed_dataset": args.speed_dataset,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    write_csv(rows, args.out / "lossless.csv")
    (args.out / "run.json").write_text(
        json.dumps({"run": run_meta, "info": info, "notes": notes, "skipped": skipped}, indent=1)
        + "\n"
    )
    write_table(rows, notes, skipped, args.out / "table.md", run_meta, info)
    plot(rows, args.out)
    print(f"\nwrote {args.out}: lossless.csv, run.json, table.md, ratio.png, ratio_vs_decode.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
