"""Octree benchmark: out-of-core build, first coarse view, errors per level, regions.

Reproduces the measurements of seed-004 §2.3.8 that a CPU can make (digest §12.3):

1. **build** - synthetic CT-like volumes (air around a body of nested ellipsoids with
   smooth texture and noise; uint16) of growing size, written to ``.npy`` without holding
   them in memory, each built by a fresh child process (``volpack.octree.builder`` from the
   file, read box by box). Columns: MB/s, ratio, peak resident memory of the child
   (``ru_maxrss``) and, with ``--limit-mb``, the address-space limit the child ran under.
2. **first view** - bytes read and seconds to open the file and decode the first level
   whose volume fits in 128^3 voxels, against decoding the whole volume (level 0).
3. **levels** - a real CT (``ct_head``, upsampled 2x per axis, the thesis's "real volumes
   upsampled") built losslessly and with ``--max-error 2``: per level, the largest node
   deviation from the index, and PSNR / max error of the level upsampled trilinearly
   (seamless) to full resolution against the input.
4. **regions** - seconds and bytes read to decode cubic regions of growing size at level 0
   from the largest synthetic volume (a fresh reader each time: cold node cache).

    python scripts/bench_octree.py [--sizes-mb 64,256,1024,4096] [--workers 2] [--limit-mb 1536]

5. **compare** - ratio and MB/s of the octree against volpack's brick codec on the head
   CT, same process, one worker (``--compare-only`` runs just this).

Writes ``results/octree/{build,levels,regions,compare}.csv``, ``results/octree/octree.png`` and
prints markdown tables. The volumes go to ``--tmp`` (default: a temporary folder) and
are deleted afterwards.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT))

from volpack.octree import Octree, build  # noqa: E402
from volpack.octree.select import by_level  # noqa: E402

OUT = ROOT / "results" / "octree"

CHILD = r"""
import json, resource, sys, time
limit = int(sys.argv[4])
if limit:
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
from volpack.octree import build
t0 = time.perf_counter()
st = build(sys.argv[1], sys.argv[2], workers=int(sys.argv[3]), force=True)
st["wall"] = time.perf_counter() - t0
# VmHWM, not ru_maxrss: Linux carries the parent's peak across fork and exec into the latter
st["maxrss"] = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status") if l.startswith("VmHWM"))
st["vmpeak"] = next(int(l.split()[1]) * 1024 for l in open("/proc/self/status") if l.startswith("VmPeak"))
print(json.dumps({k: st[k] for k in ("wall", "maxrss", "vmpeak", "ratio", "raw_nbytes", "payload_nbytes",
                                      "depth", "tasks", "mb_per_s")}))
"""


def synthetic(path: Path, side: int, seed: int = 0) -> tuple[int, int, int]:
    """A uint16 CT-like volume of about ``side^3`` voxels, written slab by slab."""
    shape = (side, side, side)
    r = np.random.default_rng(seed)
    with open(path, "wb") as f:
        np.lib.format.write_array_header_2_0(
            f, {"descr": "<u2", "fortran_order": False, "shape": shape}
        )
        y, x = np.mgrid[0:side, 0:side] / side - 0.5
        for z0 in range(0, side, 32):
            z = (np.arange(z0, min(z0 + 32, side)) / side - 0.5)[:, None, None]
            body = (z / 0.45) ** 2 + (y / 0.35) ** 2 + (x / 0.42) ** 2
            organ = ((z - 0.05) / 0.2) ** 2 + ((y + 0.05) / 0.12) ** 2 + (x / 0.15) ** 2
            bone = np.abs(np.sqrt(body) - 0.9) < 0.04
            v = np.where(body < 1, 1000 + 60 * np.sin(9 * x + 5 * y) * np.cos(7 * z), 0.0)
            v = np.where(organ < 1, 1300 + 40 * np.cos(20 * z * x), v)
            v = np.where(bone & (body < 1), 2400, v)
            v = v + np.where(body < 1, r.normal(0, 12, v.shape), 0)
            f.write(np.clip(np.rint(v), 0, 4095).astype("<u2").tobytes())
    return shape


def bench_build(sizes_mb, workers, limit_mb, tmp: Path) -> list[dict]:
    rows = []
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OPENBLAS_NUM_THREADS": "1"}
    for mb in sizes_mb:
        side = round((mb * 1e6 / 2) ** (1 / 3))
        src, dst = tmp / f"syn{mb}.npy", tmp / f"syn{mb}.vpk"
        synthetic(src, side)
        limit = int(limit_mb * 1e6) if limit_mb and mb > limit_mb else 0
        cmd = [sys.executable, "-c", CHILD, str(src), str(dst), str(workers), str(limit)]
        res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
        if res.returncode:
            print(res.stderr, file=sys.stderr)
            raise SystemExit(f"build of {mb} MB failed")
        st = json.loads(res.stdout.strip().splitlines()[-1])
        first = first_view(dst, full=mb <= 1100)
        rows.append(
            {
                "volume_mb": round(st["raw_nbytes"] / 1e6, 1),
                "shape": f"{side}^3 u16",
                "depth": st["depth"],
                "tasks": st["tasks"],
                "workers": workers,
                "build_s": round(st["wall"], 2),
                "build_mb_s": round(st["raw_nbytes"] / 1e6 / st["wall"], 2),
                "ratio": round(st["ratio"], 3),
                "peak_rss_mb": round(st["maxrss"] / 1e6, 1),
                "peak_vm_mb": round(st["vmpeak"] / 1e6, 1),
                "as_limit_mb": limit_mb if limit else None,
                "file_mb": round(dst.stat().st_size / 1e6, 2),
                **first,
            }
        )
        print(rows[-1], flush=True)
        src.unlink()
        if mb != max(sizes_mb):
            dst.unlink()
    return rows


def first_view(path: Path, full: bool) -> dict:
    t0 = time.perf_counter()
    with Octree(str(path)) as t:
        lv = next(lv for lv in range(t.depth + 1) if max(t.geometry.level_shape(lv)) <= 128)
        t.decode(lv)
        coarse_s, coarse_b = time.perf_counter() - t0, t.bytes_read
    full_s, full_b = math.nan, path.stat().st_size
    if full:  # whole volumes above 1 GB are not decoded into this process
        t0 = time.perf_counter()
        with Octree(str(path)) as t:
            t.decode(0)
            full_s, full_b = time.perf_counter() - t0, t.bytes_read
    return {
        "first_view_level": lv,
        "first_view_s": round(coarse_s, 3),
        "first_view_kb": round(coarse_b / 1e3, 1),
        "full_decode_s": round(full_s, 2),
        "full_decode_mb": round(full_b / 1e6, 2),
    }


def bench_levels(tmp: Path) -> list[dict]:
    import datasets

    from volpack.prep import resample
    from volpack.volume import Volume

    a, spacing, _ = datasets.load("ct_head")
    vol = Volume(a, spacing=spacing)
    up = resample(vol, tuple(s / 2 for s in spacing), order=1).data  # 2x per axis, trilinear
    up = np.clip(np.rint(up), -32768, 32767).astype(a.dtype)
    rows = []
    for bound in (None, 2.0):
        path = tmp / "head.vpk"
        st = build(up, str(path), max_error=bound, workers=2, force=True)
        peak = float(up.max()) - float(up.min())
        with Octree(str(path)) as t:
            for lv in range(t.depth + 1):
                out = t.assemble(by_level(t, lv), level=0, interp="linear").data
                err = np.abs(out.astype(np.float64) - up)
                mse = float(np.mean(err**2))
                rows.append(
                    {
                        "volume": f"ct_head x2 {'x'.join(map(str, up.shape))}",
                        "mode": "lossless" if bound is None else f"max-error {bound:g}",
                        "ratio": round(st["ratio"], 3),
                        "level": lv,
                        "level_shape": "x".join(map(str, t.geometry.level_shape(lv))),
                        "index_max_dev": float(t.table(lv)["maxdev"].max()),
                        "max_error": float(err.max()),
                        "psnr_db": round(10 * math.log10(peak**2 / mse), 2) if mse else None,
                    }
                )
                print(rows[-1], flush=True)
        path.unlink()
    return rows


def bench_regions(path: Path) -> list[dict]:
    rows = []
    with Octree(str(path)) as t:
        shape = t.shape
    for side in (16, 32, 64, 128, 256, 512):
        if side > min(shape):
            break
        c = [n // 2 - side // 2 for n in shape]
        roi = ",".join(f"{a}:{a + side}" for a in c)
        t0 = time.perf_counter()
        with Octree(str(path)) as t:
            t.decode(0, roi)
            rows.append(
                {
                    "region": f"{side}^3",
                    "voxels": side**3,
                    "seconds": round(time.perf_counter() - t0, 4),
                    "kb_read": round(t.bytes_read / 1e3, 1),
                    "nodes_decoded": t.decoded_nodes,
                    "file_mb": round(path.stat().st_size / 1e6, 2),
                }
            )
        print(rows[-1], flush=True)
    return rows


def bench_compare() -> list[dict]:
    """The octree against volpack's brick codec on the head CT: same process, one worker."""
    import io

    import datasets

    from volpack import api

    a, _, _ = datasets.load("ct_head")
    rows = []
    for bound in (None, 2.0):
        for name in ("brick codec (64^3)", "octree (k = 16)"):
            best = math.inf
            for _ in range(2):
                buf = io.BytesIO()
                t0 = time.perf_counter()
                if name.startswith("octree"):
                    build(a, buf, max_error=bound, workers=1)
                else:
                    api.compress(a, buf, max_error=bound, workers=1)
                best = min(best, time.perf_counter() - t0)
            t0 = time.perf_counter()
            if name.startswith("octree"):
                with Octree(buf.getvalue()) as t:
                    out = t.decode(0).data
            else:
                out = api.decompress(buf.getvalue()).data
            dec = time.perf_counter() - t0
            rows.append(
                {
                    "volume": "ct_head 108x256x256 int16",
                    "method": name,
                    "mode": "lossless" if bound is None else f"max-error {bound:g}",
                    "ratio": round(a.nbytes / len(buf.getvalue()), 3),
                    "encode_mb_s": round(a.nbytes / 1e6 / best, 1),
                    "decode_mb_s": round(a.nbytes / 1e6 / dec, 1),
                    "max_error": float(np.abs(out.astype(np.float64) - a).max()),
                }
            )
            print(rows[-1], flush=True)
    return rows


def write_csv(name: str, rows: list[dict]) -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / name, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def markdown(rows: list[dict]) -> str:
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    return "\n".join(lines)


def chart(build_rows, level_rows, region_rows) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 3, figsize=(15, 4.2))
    v = [r["volume_mb"] for r in build_rows]
    ax[0].plot(v, [r["peak_rss_mb"] for r in build_rows], "o-", label="peak RSS of the build")
    ax[0].plot(v, v, "k--", lw=0.8, label="volume size")
    ax[0].set(
        xscale="log",
        yscale="log",
        xlabel="volume (MB)",
        ylabel="MB",
        title="Out-of-core build: peak memory",
    )
    ax[0].legend()
    for mode in sorted({r["mode"] for r in level_rows}):
        rs = [r for r in level_rows if r["mode"] == mode and r["psnr_db"] is not None]
        ax[1].plot([r["level"] for r in rs], [r["psnr_db"] for r in rs], "o-", label=mode)
    ax[1].set(
        xlabel="level (0 = full resolution)",
        ylabel="PSNR (dB), trilinear to full res",
        title="ct_head x2: quality per level",
    )
    ax[1].legend()
    ax[2].plot(
        [r["voxels"] for r in region_rows],
        [r["seconds"] for r in region_rows],
        "o-",
        label="seconds",
    )
    ax2 = ax[2].twinx()
    ax2.plot(
        [r["voxels"] for r in region_rows],
        [r["kb_read"] / 1e3 for r in region_rows],
        "s--",
        color="C1",
        label="MB read",
    )
    ax[2].set(
        xscale="log",
        yscale="log",
        xlabel="region voxels",
        ylabel="seconds",
        title="Region decode at level 0 (cold cache)",
    )
    ax2.set(yscale="log", ylabel="MB read")
    fig.tight_layout()
    fig.savefig(OUT / "octree.png", dpi=110)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes-mb", default="64,256,1024")
    p.add_argument("--workers", type=int, default=2)
    p.add_argument(
        "--limit-mb",
        type=float,
        default=0.0,
        help="RLIMIT_AS (MB) for build children whose volume exceeds it",
    )
    p.add_argument("--tmp", default=None)
    p.add_argument(
        "--compare-only",
        action="store_true",
        help="only the octree against the brick codec on the head CT",
    )
    args = p.parse_args()
    sizes = [int(s) for s in args.sizes_mb.split(",")]
    with tempfile.TemporaryDirectory() as w:  # compile or load the kernels before timing
        build(np.arange(40**3, dtype=np.uint16).reshape(40, 40, 40), f"{w}/w.vpk")
        with Octree(f"{w}/w.vpk") as t:
            t.decode(0)
    compare_rows = bench_compare()
    write_csv("compare.csv", compare_rows)
    print(markdown(compare_rows) + "\n")
    if args.compare_only:
        return
    with tempfile.TemporaryDirectory(dir=args.tmp) as d:
        tmp = Path(d)
        build_rows = bench_build(sizes, args.workers, args.limit_mb, tmp)
        region_rows = bench_regions(tmp / f"syn{max(sizes)}.vpk")
        level_rows = bench_levels(tmp)
    write_csv("build.csv", build_rows)
    write_csv("levels.csv", level_rows)
    write_csv("regions.csv", region_rows)
    chart(build_rows, level_rows, region_rows)
    for rows in (build_rows, level_rows, region_rows):
        print(markdown(rows) + "\n")


if __name__ == "__main__":
    main()
