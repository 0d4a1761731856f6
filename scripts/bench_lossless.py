"""Lossless benchmark: volpack's wavelet codec against peer codecs on real volumes.

Every method runs in this process on the same array. For each one we report

* ratio: raw bytes of the volume in its own dtype (e.g. 2 bytes a voxel for int16 CT)
  divided by the compressed bytes, whatever the codec was fed internally;
* encode / decode MB/s: MB = 1e6 bytes of raw voxels, best of ``--repeat`` runs;
* exact: the decoded array equals the original, dtype and shape included. A codec row
  that does not round-trip exactly raises.

Peers: zstd (levels 3 and 19, plain and byte-shuffled), blosc2 (zstd clevel 9 +
bitshuffle), zfp reversible (on an int32 and on a float32 copy), and JPEG-LS, JPEG 2000
(reversible 5/3) and JPEG-XL (lossless, default effort) via imagecodecs, slice by slice
along z. JPEG-LS and JPEG-XL take unsigned samples only, so signed volumes are shifted to
unsigned first (int16 + 32768 -> uint16, done as a sign-bit flip) and back after decoding.
Slice codecs with 2 workers code the slices in 2 threads (imagecodecs releases the GIL).

volpack rows: every wavelet (53, 26, haar, 97m) with every entropy coder (arith,
huffman, rle) at 1 worker, named ``volpack-<wavelet>-<coder>``; the default (53 + arith)
and 53 + huffman also run at 2 workers, for the 2-worker speed-up. The defaults and all
peers are timed best of ``--repeat`` runs, the other wavelet x coder rows best of
``--grid-repeat`` runs (default 2): their ratios are what matters, and ratios do not
depend on the repeat count. volpack rows are skipped with a warning if ``volpack.api``
cannot be imported or a combination fails its warm-up round trip; a row whose codec
raises on a real volume is skipped with a warning and listed in ``table.md``. A row that
decodes to anything but the original array still aborts the run.

    python scripts/fetch_data.py                       # once
    python scripts/bench_lossless.py --quick           # 128^3 centre crops, fast
    python scripts/bench_lossless.py --datasets ct_head

Outputs in ``--out`` (default ``results/lossless``): ``lossless.csv`` (every row; written
after each dataset so an interrupted run keeps what it measured), ``ratio.png`` (per
dataset: the best volpack wavelet for each coder, and every peer), ``wavelets.png``
(ratio of each wavelet x coder per dataset), ``ratio_vs_decode.png`` and ``table.md``
(ratios of volpack-53-arith, volpack-53-huffman and the peers per dataset; every method
on ct_head with speeds and the 2-worker speed-up). ``--replot`` redraws the charts and the
table from the CSV.
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
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
FIELDS = [
    "dataset",
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
VOLPACK_WAVELETS = ("53", "26", "haar", "97m")
VOLPACK_CODERS = ("arith", "huffman", "rle")
# (wavelet, coder) pairs that also run at 2 workers and are timed with --repeat.
VOLPACK_DEFAULTS = (("53", "arith"), ("53", "huffman"))
WORKERS = (1, 2)
SPEEDUP_DATASET = "ct_head"


@dataclass
class Method:
    name: str
    workers: int
    encode: Callable[[np.ndarray], object]  # -> bytes, or list of bytes (one per slice)
    decode: Callable[[object], np.ndarray]
    note: str = ""
    grid: bool = False  # a volpack wavelet x coder row timed with --grid-repeat


def vp_name(wavelet: str, coder: str) -> str:
    return f"volpack-{wavelet}-{coder}"


def warn(message: str) -> None:
    """A skipped method: say so on stderr and go on."""
    print(f"warning: {message}", file=sys.stderr, flush=True)


def nbytes_of(blob) -> int:
    if isinstance(blob, (bytes, bytearray, memoryview)):
        return len(blob)
    return sum(len(b) for b in blob)


# ---------------------------------------------------------------------------------------
# Peers


def _to_unsigned(a: np.ndarray) -> np.ndarray:
    """Signed -> unsigned of the same width by adding 2**(bits-1) (a sign-bit flip)."""
    if a.dtype.kind != "i":
        return a
    u = np.dtype(f"u{a.dtype.itemsize}")
    return a.view(u) ^ u.type(1 << (8 * a.dtype.itemsize - 1))


def _from_unsigned(u: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if dtype.kind != "i":
        return u
    return (u ^ u.dtype.type(1 << (8 * dtype.itemsize - 1))).view(dtype)


def _zstd_methods(dtype: np.dtype, shape) -> list[Method]:
    import zstandard

    out = []
    size = dtype.itemsize
    dctx = zstandard.ZstdDecompressor()
    for level in (3, 19):
        cctx = zstandard.ZstdCompressor(level=level)
        out.append(
            Method(
                f"zstd-{level}",
                1,
                lambda a, c=cctx: c.compress(a),
                lambda b: np.frombuffer(dctx.decompress(b), dtype).reshape(shape),
            )
        )
        if size > 1:  # byte shuffle: all first bytes, then all second bytes, ...
            out.append(
                Method(
                    f"zstd-{level}+shuffle",
                    1,
                    lambda a, c=cctx: c.compress(a.view(np.uint8).reshape(-1, size).T.copy()),
                    lambda b: (
                        np.frombuffer(dctx.decompress(b), np.uint8)
                        .reshape(size, -1)
                        .T.copy()
                        .view(dtype)
                        .reshape(shape)
                    ),
                    "numpy byte shuffle",
                )
            )
    return out


def _blosc2_methods(dtype: np.dtype, shape) -> list[Method]:
    import blosc2

    out = []
    for w in WORKERS:
        cparams = blosc2.CParams(
            codec=blosc2.Codec.ZSTD,
            clevel=9,
            filters=[blosc2.Filter.BITSHUFFLE],
            typesize=dtype.itemsize,
            nthreads=w,
        )
        dparams = blosc2.DParams(nthreads=w)
        out.append(
            Method(
                "blosc2-zstd9+bitshuffle",
                w,
                lambda a, p=cparams: blosc2.compress2(a, cparams=p),
                lambda b, p=dparams: np.frombuffer(blosc2.decompress2(b, dparams=p), dtype).reshape(
                    shape
                ),
                f"python-blosc2 {blosc2.__version__}, typesize = itemsize, workers = nthreads",
            )
        )
    return out


def _zfp_methods(dtype: np.dtype, shape) -> list[Method]:
    import zfpy

    out = [
        Method(
            "zfp-rev(int32)",
            1,
            lambda a: zfpy.compress_numpy(a.astype(np.int32)),
            lambda b: zfpy.decompress_numpy(b).astype(dtype),
            "reversible mode on an int32 copy",
        )
    ]
    if dtype.itemsize <= 2:  # float32 holds every 8/16-bit integer exactly
        out.append(
            Method(
                "zfp-rev(float32)",
                1,
                lambda a: zfpy.compress_numpy(a.astype(np.float32)),
                lambda b: zfpy.decompress_numpy(b).astype(dtype),
                "reversible mode on a float32 copy",
            )
        )
    return out


def _slice_methods(dtype: np.dtype, shape) -> list[Method]:
    import imagecodecs as ic

    shift = "; signed volumes shifted by +2**(bits-1) to unsigned and back"
    codecs = [
        (
            "jpegls",
            lambda s: ic.jpegls_encode(_to_unsigned(s)),
            lambda b: _from_unsigned(ic.jpegls_decode(b), dtype),
            f"CharLS ({ic.jpegls_version()}){shift}",
        ),
        (
            "jpeg2k",
            lambda s: ic.jpeg2k_encode(s, level=0, reversible=True, numthreads=1),
            lambda b: ic.jpeg2k_decode(b, numthreads=1).astype(dtype, copy=False),
            f"{ic.jpeg2k_version()}, reversible 5/3, fed the volume's own dtype (int16 too)",
        ),
        (
            "jpegxl",
            lambda s: ic.jpegxl_encode(_to_unsigned(s), lossless=True, numthreads=1),
            lambda b: _from_unsigned(ic.jpegxl_decode(b, numthreads=1), dtype),
            f"{ic.jpegxl_version()}, lossless, default effort (7){shift}",
        ),
    ]
    out = []
    for name, enc, dec, note in codecs:
        for w in WORKERS:
            out.append(
                Method(
                    name,
                    w,
                    lambda a, e=enc, w=w: _map(e, list(a), w),
                    lambda bs, d=dec, w=w: np.stack(_map(d, bs, w)).reshape(shape),
                    note + "; coded per z slice, workers = threads over slices",
                )
            )
    return out


_POOLS: dict[int, ThreadPoolExecutor] = {}


def _map(fn, items, workers: int) -> list:
    if workers <= 1:
        return [fn(x) for x in items]
    pool = _POOLS.setdefault(workers, ThreadPoolExecutor(workers))
    return list(pool.map(fn, items))


def peer_methods(dtype: np.dtype, shape) -> list[Method]:
    out: list[Method] = []
    for make in (_zstd_methods, _blosc2_methods, _zfp_methods, _slice_methods):
        try:
            out += make(dtype, shape)
        except ImportError as exc:
            warn(f"skipping {make.__name__[1:-8]}: {exc}")
    return out


# ---------------------------------------------------------------------------------------
# volpack


def volpack_methods(dtype: np.dtype, shape, brick: int | None) -> list[Method]:
    try:
        from volpack import api
    except Exception as exc:  # the codec may not exist yet
        warn(f"skipping volpack rows: cannot import volpack.api ({exc!r})")
        return []
    opts = {} if brick is None else {"brick": brick}
    probe = _warmup_array(dtype)
    first, rest = [], []
    for wavelet in VOLPACK_WAVELETS:
        for coder in VOLPACK_CODERS:
            name = vp_name(wavelet, coder)
            try:  # also compiles the numba kernels before anything is timed
                blob = api.compress_array(probe, wavelet=wavelet, coder=coder, **opts)
                back = api.decompress_array(blob)
            except Exception as exc:
                warn(f"skipping {name}: compress/decompress failed ({exc!r})")
                continue
            if not (back.dtype == probe.dtype and np.array_equal(back, probe)):
                raise AssertionError(f"{name}: warm-up round trip is not exact")
            default = (wavelet, coder) in VOLPACK_DEFAULTS
            for w in WORKERS if default else (1,):
                (first if default else rest).append(
                    Method(
                        name,
                        w,
                        lambda a, v=wavelet, c=coder, w=w: api.compress_array(
                            a, wavelet=v, coder=c, workers=w, **opts
                        ),
                        lambda b, w=w: api.decompress_array(b, workers=w),
                        f"api.compress_array(wavelet={wavelet!r}, coder={coder!r}, "
                        f"workers=..., brick={brick or 'default'})",
                        grid=not default,
                    )
                )
    return first + rest


def _warmup_array(dtype: np.dtype) -> np.ndarray:
    rng = np.random.default_rng(0)
    info = np.iinfo(dtype)
    z, y, x = np.mgrid[:24, :40, :36]
    smooth = (z * 3 + y * 2 + x) % 200
    a = smooth + rng.integers(-3, 4, smooth.shape)
    return np.clip(a + max(int(info.min), -100), info.min, info.max).astype(dtype)


# ---------------------------------------------------------------------------------------
# Running


def measure(method: Method, a: np.ndarray, repeat: int) -> dict:
    raw = a.nbytes
    enc_t, dec_t = [], []
    blob = back = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        blob = method.encode(a)
        enc_t.append(time.perf_counter() - t0)
    for _ in range(repeat):
        t0 = time.perf_counter()
        back = method.decode(blob)
        dec_t.append(time.perf_counter() - t0)
    back = np.asarray(back)
    exact = back.dtype == a.dtype and back.shape == a.shape and np.array_equal(back, a)
    if not exact:
        raise AssertionError(
            f"{method.name} (workers {method.workers}) did not round-trip exactly: "
            f"got {back.dtype} {back.shape}, expected {a.dtype} {a.shape}"
        )
    size = nbytes_of(blob)
    return {
        "method": method.name,
        "workers": method.workers,
        "repeat": repeat,
        "ratio": raw / size,
        "encode_mb_s": raw / 1e6 / min(enc_t),
        "decode_mb_s": raw / 1e6 / min(dec_t),
        "exact": exact,
        "raw_bytes": raw,
        "compressed_bytes": size,
    }


def center_crop(a: np.ndarray, n: int = 128) -> np.ndarray:
    sl = tuple(slice(max(0, (s - n) // 2), max(0, (s - n) // 2) + min(s, n)) for s in a.shape)
    return np.ascontiguousarray(a[sl])


def run(
    names,
    repeat: int,
    grid_repeat: int,
    quick: bool,
    brick: int | None,
    peers: bool,
    volpack: bool,
    checkpoint: Callable[[list], None] | None = None,
):
    """Measure every method on every dataset; return (rows, notes, skipped)."""
    rows, notes, skipped = [], {}, []
    for name in names:
        a, _, desc = datasets.load(name)
        if quick:
            a = center_crop(a)
        shape = "x".join(map(str, a.shape))
        print(f"\n== {name}: {shape} {a.dtype} ({a.nbytes / 1e6:.2f} MB) {desc}", flush=True)
        t_ds = time.perf_counter()
        methods = []
        if volpack:
            methods += volpack_methods(a.dtype, a.shape, brick)
        if peers:
            methods += peer_methods(a.dtype, a.shape)
        for m in methods:
            try:
                result = measure(m, a, grid_repeat if m.grid else repeat)
            except AssertionError:
                raise  # not exact: never let that pass
            except Exception as exc:
                warn(f"{name}: {m.name} (workers {m.workers}) failed, row skipped ({exc!r})")
                skipped.append(f"{name}: {m.name} (workers {m.workers}): {exc!r}")
                continue
            row = {"dataset": name, "shape": shape, "dtype": str(a.dtype), **result}
            rows.append(row)
            if m.note:
                notes[m.name] = m.note
            print(
                f"  {m.name:24s} w{m.workers}  ratio {row['ratio']:6.3f}  "
                f"enc {row['encode_mb_s']:8.1f} MB/s  dec {row['decode_mb_s']:8.1f} MB/s",
                flush=True,
            )
        print(f"  ({name} took {time.perf_counter() - t_ds:.0f} s)", flush=True)
        if checkpoint is not None:
            checkpoint(rows)
    return rows, notes, skipped


# ---------------------------------------------------------------------------------------
# Outputs


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
        for k in ("workers", "raw_bytes", "compressed_bytes"):
            r[k] = int(r[k])
        r["repeat"] = int(r.get("repeat") or 0)
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
    for mod in ("numba", "volpack", "zstandard", "blosc2", "zfpy", "imagecodecs"):
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
    return method.startswith("volpack-")


def _by_dataset(rows) -> dict[str, list[dict]]:
    out: dict[str, list[dict]] = {}
    for r in rows:
        out.setdefault(r["dataset"], []).append(r)
    return out


def _peer_names(rows) -> list[str]:
    return list(dict.fromkeys(r["method"] for r in rows if not _is_volpack(r["method"])))


def _one(rows, method: str, workers: int = 1) -> dict | None:
    for r in rows:
        if r["method"] == method and r["workers"] == workers:
            return r
    return None


def _bold_best(values: list[float | None], fmt: str = "{:.3f}") -> list[str]:
    """Format values; the largest (ties at the printed precision included) in bold."""
    shown = [None if v is None else fmt.format(v) for v in values]
    best = max((float(x) for x in shown if x is not None), default=None)
    return ["—" if x is None else (f"**{x}**" if float(x) == best else x) for x in shown]


def machine_line(info: dict[str, str]) -> str:
    libs = ", ".join(
        f"{k} {info[k]}" for k in ("volpack", "zstandard", "blosc2", "zfpy", "imagecodecs")
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
    peers = _peer_names(rows)
    base = [vp_name(*d) for d in VOLPACK_DEFAULTS]
    lines = [
        "# Lossless benchmark",
        "",
        machine_line(info),
        "",
        f"Ratio = raw bytes in the volume's own dtype / compressed bytes. MB/s counts raw "
        f"voxel bytes (1 MB = 10⁶ B), best of {run['repeat']} runs (best of "
        f"{run['grid_repeat']} for the volpack wavelet × coder rows other than "
        f"{' and '.join(base)})"
        + (", on 128³ centre crops" if run["quick"] else "")
        + ". Every row round-trips exactly (dtype, shape and values checked). Speeds are "
        "from a shared machine: compare rows within one run, not across runs. All rows "
        "are in `lossless.csv`.",
        "",
        "## Ratio per dataset",
        "",
        f"Best of {', '.join(base)} and the peers in bold (1 worker; ratios do not depend "
        "on the worker count). The last column, outside the comparison, is the best volpack "
        "wavelet × coder on that dataset (see `wavelets.png`).",
        "",
    ]
    cols = base + peers
    lines.append("| dataset | " + " | ".join(cols) + " | best volpack wavelet×coder |")
    lines.append("|---|" + "---:|" * len(cols) + "---|")
    for ds, rs in by_ds.items():
        vals = [(_one(rs, m) or {}).get("ratio") for m in cols]
        grid = [r for r in rs if _is_volpack(r["method"]) and r["workers"] == 1]
        top = max(grid, key=lambda r: r["ratio"], default=None)
        extra = "—" if top is None else f"{top['ratio']:.3f} ({top['method'][8:]})"
        label = f"{ds} ({rs[0]['shape']} {rs[0]['dtype']})"
        lines.append(f"| {label} | " + " | ".join(_bold_best(vals)) + f" | {extra} |")
    lines.append("")

    ds = run.get("speedup_dataset", SPEEDUP_DATASET)
    if ds not in by_ds and by_ds:
        ds = next(iter(by_ds))
    if ds in by_ds:
        rs = by_ds[ds]
        r0 = rs[0]
        lines += [
            f"## Every method on {ds} ({r0['shape']} {r0['dtype']}, "
            f"{r0['raw_bytes'] / 1e6:.2f} MB)",
            "",
            "Ratio and speeds at 1 worker; 2-worker speed-up = MB/s at 2 workers / MB/s at "
            "1 worker, for the volpack rows that ran at 2 workers. Sorted by ratio.",
            "",
            "| method | ratio | encode MB/s | decode MB/s | runs | 2-worker speed-up "
            "encode | 2-worker speed-up decode |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        ones = sorted(
            (r for r in rs if r["workers"] == 1), key=lambda r: (-r["ratio"], r["method"])
        )
        best = f"{ones[0]['ratio']:.3f}" if ones else None
        for r in ones:
            two = _one(rs, r["method"], 2) if _is_volpack(r["method"]) else None
            up_e = up_d = "—"
            if two is not None:
                up_e = f"{two['encode_mb_s'] / r['encode_mb_s']:.2f}×"
                up_d = f"{two['decode_mb_s'] / r['decode_mb_s']:.2f}×"
            ratio = f"{r['ratio']:.3f}"
            if ratio == best:
                ratio = f"**{ratio}**"
            lines.append(
                f"| {r['method']} | {ratio} | {r['encode_mb_s']:.1f} | "
                f"{r['decode_mb_s']:.1f} | {r['repeat'] or '?'} | {up_e} | {up_d} |"
            )
        lines.append("")
    if skipped:
        lines += ["Skipped rows (the codec raised):", ""]
        lines += [f"- {x}" for x in skipped]
        lines.append("")
    if notes:
        lines += ["Notes:", ""]
        vp = [k for k in notes if _is_volpack(k)]
        if vp:  # one line for the volpack grid instead of one per row
            example = notes[vp[0]]
            for key in ("wavelet=", "coder="):
                i = example.find(key)
                if i >= 0:
                    j = example.find(",", i)
                    example = example[: i + len(key)] + "..." + example[j:]
            lines.append(f"- volpack-<wavelet>-<coder>: {example}")
        lines += [f"- {k}: {v}" for k, v in sorted(notes.items()) if not _is_volpack(k)]
        lines.append("")
    lines.append(
        f"<!-- args: repeat={run['repeat']} grid_repeat={run['grid_repeat']} "
        f"quick={run['quick']} brick={run['brick']} -->"
    )
    path.write_text("\n".join(lines) + "\n")


# Colours: volpack by coder, peers by family.
_VP_COLORS = {"arith": "#c0392b", "huffman": "#e67e22", "rle": "#8e44ad"}
# zstd (4 blues), blosc2 (green), zfp (2 greys), slice codecs (3 pastels), spares.
_PEER_COLORS = (
    "#9ecae1 #6baed6 #3182bd #08519c #31a354 #bdbdbd #737373 #fdd0a2 #a1d99b #fa9fb5 "
    "#17becf #bcbd22 #8c564b"
).split()


def _colors(rows) -> dict[str, str]:
    colors = {}
    for m in dict.fromkeys(r["method"] for r in rows):
        if _is_volpack(m):
            colors[m] = _VP_COLORS.get(m.rsplit("-", 1)[1], "#d62728")
    for i, m in enumerate(_peer_names(rows)):
        colors[m] = _PEER_COLORS[i % len(_PEER_COLORS)]
    return colors


def plot(rows, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    by_ds = _by_dataset(rows)
    dsets = list(by_ds)
    peers = _peer_names(rows)
    colors = _colors(rows)
    n = len(dsets)
    cols = min(3, n)
    nrows = (n + cols - 1) // cols

    # ratio.png: per dataset, the best wavelet for each volpack coder, then every peer.
    labels = [f"volpack {c} (best wavelet)" for c in VOLPACK_CODERS] + peers
    fig, axes = plt.subplots(
        nrows,
        cols,
        figsize=(5.0 * cols + 1.6, 0.26 * len(labels) * nrows + 1.0 * nrows + 0.6),
        squeeze=False,
        sharey=True,
    )
    for ax, d in zip(axes.flat, dsets):
        rs = [r for r in by_ds[d] if r["workers"] == 1]
        vals, cs, notes = [], [], []
        for c in VOLPACK_CODERS:
            cand = [r for r in rs if _is_volpack(r["method"]) and r["method"].endswith("-" + c)]
            top = max(cand, key=lambda r: r["ratio"], default=None)
            vals.append(top["ratio"] if top else 0.0)
            cs.append(_VP_COLORS[c])
            notes.append(f"{top['ratio']:.2f} ({top['method'].split('-')[1]})" if top else "—")
        for m in peers:
            r = _one(rs, m)
            vals.append(r["ratio"] if r else 0.0)
            cs.append(colors[m])
            notes.append(f"{r['ratio']:.2f}" if r else "—")
        ys = np.arange(len(labels))
        ax.barh(ys, vals, color=cs, edgecolor="k", linewidth=0.3)
        best = max(vals)
        for y, v, t in zip(ys, vals, notes):
            ax.text(
                v + best * 0.01,
                y,
                t,
                va="center",
                fontsize=7,
                fontweight="bold" if v == best else "normal",
            )
        ax.set_xlim(0, best * 1.25)
        ax.axvline(best, color="k", lw=0.5, ls=":")
        ax.set_yticks(ys)
        ax.set_yticklabels(labels, fontsize=8)
        r0 = by_ds[d][0]
        ax.set_title(f"{d} ({r0['shape']} {r0['dtype']})", fontsize=9)
        ax.tick_params(axis="x", labelsize=7)
        ax.grid(axis="x", alpha=0.3)
    axes.flat[0].invert_yaxis()  # shared: first label on top in every panel
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    for ax in axes[-1]:
        ax.set_xlabel("compression ratio (raw / compressed)", fontsize=8)
    fig.suptitle(
        "Lossless compression ratio, 1 worker (volpack: best of the 4 wavelets per coder, "
        "wavelet in brackets)",
        fontsize=10,
    )
    fig.tight_layout(rect=(0, 0, 1, 0.985))
    fig.savefig(out / "ratio.png", dpi=110)
    plt.close(fig)

    # wavelets.png: heat map, datasets x (coder, wavelet), colour = ratio / row best.
    combos = [(w, c) for c in VOLPACK_CODERS for w in VOLPACK_WAVELETS]
    grid = np.full((n, len(combos)), np.nan)
    for i, d in enumerate(dsets):
        for j, (w, c) in enumerate(combos):
            r = _one(by_ds[d], vp_name(w, c))
            if r is not None:
                grid[i, j] = r["ratio"]
    if np.isfinite(grid).any():
        rel = grid / np.nanmax(grid, axis=1, keepdims=True)
        top = [f"{np.nanmax(row):.2f}" if np.isfinite(row).any() else "" for row in grid]
        fig, ax = plt.subplots(figsize=(1.0 + 0.72 * len(combos) + 2.6, 0.9 + 0.42 * n + 0.9))
        vmin = max(0.0, float(np.nanmin(rel)) - 0.02)
        im = ax.imshow(rel, cmap="viridis", vmin=vmin, vmax=1.0, aspect="auto")
        for i in range(n):
            for j in range(len(combos)):
                if np.isfinite(grid[i, j]):
                    dark = (rel[i, j] - vmin) / max(1.0 - vmin, 1e-9) < 0.6
                    ax.text(
                        j,
                        i,
                        f"{grid[i, j]:.2f}",
                        ha="center",
                        va="center",
                        fontsize=7.5,
                        color="w" if dark else "k",
                        fontweight="bold" if f"{grid[i, j]:.2f}" == top[i] else "normal",
                    )
                else:
                    ax.text(j, i, "—", ha="center", va="center", fontsize=7.5)
        ax.set_xticks(range(len(combos)))
        ax.set_xticklabels([w for w, _ in combos], fontsize=8)
        ax.set_yticks(range(n))
        ax.set_yticklabels([f"{d} ({by_ds[d][0]['dtype']})" for d in dsets], fontsize=8)
        k = len(VOLPACK_WAVELETS)
        for g, c in enumerate(VOLPACK_CODERS):
            ax.text(
                g * k + (k - 1) / 2,
                -0.75,
                c,
                ha="center",
                va="bottom",
                fontsize=9,
                fontweight="bold",
            )
            if g:
                ax.axvline(g * k - 0.5, color="w", lw=2.5)
        ax.set_ylim(n - 0.5, -1.3)
        ax.set_xlabel("wavelet (grouped by entropy coder)", fontsize=8)
        cb = fig.colorbar(im, ax=ax, fraction=0.04, pad=0.02)
        cb.set_label("ratio / best volpack ratio on the dataset", fontsize=8)
        cb.ax.tick_params(labelsize=7)
        ax.set_title(
            "volpack lossless ratio per wavelet × coder (1 worker; best per row in bold)",
            fontsize=10,
            pad=18,
        )
        for sp in ax.spines.values():
            sp.set_visible(False)
        fig.tight_layout()
        fig.savefig(out / "wavelets.png", dpi=120)
        plt.close(fig)

    # ratio_vs_decode.png: peers and the default volpack rows labelled; the other
    # wavelet x coder rows as small unlabelled dots in their coder's colour.
    base = {vp_name(*d) for d in VOLPACK_DEFAULTS}
    fig, axes = plt.subplots(
        nrows, cols, figsize=(max(7.0, 5.2 * cols), 4.4 * nrows), squeeze=False
    )
    for ax, d in zip(axes.flat, dsets):
        rs = by_ds[d]
        for r in rs:
            minor = _is_volpack(r["method"]) and r["method"] not in base
            ax.scatter(
                r["decode_mb_s"],
                r["ratio"],
                color=colors[r["method"]],
                marker="o" if r["workers"] == 1 else "s",
                s=12 if minor else 36,
                edgecolors="none" if minor else "k",
                linewidths=0.4,
                alpha=0.6 if minor else 1.0,
                zorder=2 if minor else 3,
            )
        labelled = set()
        for r in sorted(rs, key=lambda r: r["workers"]):  # one label per method
            if r["method"] in labelled or (_is_volpack(r["method"]) and r["method"] not in base):
                continue
            labelled.add(r["method"])
            ax.annotate(
                r["method"],
                (r["decode_mb_s"], r["ratio"]),
                fontsize=6,
                xytext=(3, 3),
                textcoords="offset points",
            )
        ax.set_xscale("log")
        ratios = [r["ratio"] for r in rs]
        if max(ratios) / min(ratios) > 8:
            ax.set_yscale("log")
            ax.yaxis.set_major_locator(matplotlib.ticker.LogLocator(subs=(1.0, 2.0, 5.0)))
            ax.yaxis.set_major_formatter(matplotlib.ticker.FormatStrFormatter("%g"))
            ax.yaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(f"{d} ({rs[0]['shape']} {rs[0]['dtype']})", fontsize=9)
        ax.set_xlabel("decode MB/s (log)", fontsize=8)
        ax.set_ylabel("ratio", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3, which="both")
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    fig.suptitle(
        "Lossless: compression ratio vs decode speed (circle = 1 worker, square = 2 workers;\n"
        "small dots = other volpack wavelet × coder rows: red arith, orange huffman, purple rle)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(out / "ratio_vs_decode.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--datasets", nargs="+", metavar="NAME", help="datasets to run (default: every fetched one)"
    )
    parser.add_argument("datasets_pos", nargs="*", metavar="NAME", help="same as --datasets")
    parser.add_argument(
        "--repeat",
        type=int,
        default=3,
        help="best of N runs for peers and the default volpack rows (default 3)",
    )
    parser.add_argument(
        "--grid-repeat",
        type=int,
        default=2,
        help="best of N runs for the other volpack wavelet x coder rows (default 2)",
    )
    parser.add_argument("--quick", action="store_true", help="crop each volume to 128^3 centre")
    parser.add_argument("--out", type=Path, default=ROOT / "results" / "lossless")
    parser.add_argument("--brick", type=int, default=None, help="volpack brick size")
    parser.add_argument("--no-volpack", action="store_true", help="peers only")
    parser.add_argument("--no-peers", action="store_true", help="volpack only")
    parser.add_argument(
        "--speedup-dataset",
        default=SPEEDUP_DATASET,
        help=f"dataset of the every-method table (default {SPEEDUP_DATASET})",
    )
    parser.add_argument(
        "--replot",
        action="store_true",
        help="redraw the charts and table.md from OUT/lossless.csv and OUT/run.json, and exit",
    )
    args = parser.parse_args(argv)

    if args.replot:
        rows = read_csv(args.out / "lossless.csv")
        plot(rows, args.out)
        meta_path = args.out / "run.json"
        if meta_path.is_file():
            meta = json.loads(meta_path.read_text())
            write_table(
                rows,
                meta["notes"],
                meta["skipped"],
                args.out / "table.md",
                meta["run"],
                meta["info"],
            )
        return 0

    names = (args.datasets or []) + args.datasets_pos or datasets.names()
    if not names:
        parser.error("no dataset fetched: run scripts/fetch_data.py first")
    missing = [n for n in names if n not in datasets.names(available_only=False)]
    if missing:
        parser.error(f"unknown dataset(s) {', '.join(missing)}")
    args.repeat = max(1, args.repeat)
    args.grid_repeat = max(1, args.grid_repeat)

    info = machine_info()
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    rows, notes, skipped = run(
        names,
        args.repeat,
        args.grid_repeat,
        args.quick,
        args.brick,
        peers=not args.no_peers,
        volpack=not args.no_volpack,
        checkpoint=lambda rows: write_csv(rows, args.out / "lossless.csv"),
    )
    if not rows:
        print("nothing measured", file=sys.stderr)
        return 1
    info["load average at end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    run_meta = {
        "repeat": args.repeat,
        "grid_repeat": args.grid_repeat,
        "quick": args.quick,
        "brick": args.brick,
        "speedup_dataset": args.speedup_dataset,
        "seconds": round(time.perf_counter() - t0, 1),
    }
    write_csv(rows, args.out / "lossless.csv")
    (args.out / "run.json").write_text(
        json.dumps({"run": run_meta, "info": info, "notes": notes, "skipped": skipped}, indent=1)
        + "\n"
    )
    write_table(rows, notes, skipped, args.out / "table.md", run_meta, info)
    plot(rows, args.out)
    print(
        f"\nwrote {args.out}/lossless.csv, run.json, table.md, ratio.png, wavelets.png, "
        f"ratio_vs_decode.png ({run_meta['seconds']:.0f} s)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
