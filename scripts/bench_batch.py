"""Batch throughput: files/s and MB/s of `volpack.batch.run` on a folder of real volumes.

The folder holds copies of cached datasets (``scripts/datasets.py``) as ``.npy`` files,
a few copies each (about ten files). Each configuration compresses the whole folder
losslessly with ``verify="decode"`` into a fresh output folder:

- local, 1 worker (inline), 2 workers on a process pool, 2 workers on a thread pool;
- a 2-worker Dask ``LocalCluster`` (worker processes, one thread each).

Every configuration must give the same output bytes (checked by sha256). The kernels are
compiled (or loaded from the disk cache) once before timing in this process; worker
processes load them from the disk cache as part of the measured time, as a user sees it.

    python scripts/bench_batch.py [--copies 3] [--names ct_head,mri_ch2,...]

Writes ``results/batch/batch.csv`` and ``results/batch/table.md``.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

import datasets  # noqa: E402

from volpack import api, batch  # noqa: E402

DEFAULT_NAMES = ("ct_head", "mri_ch2", "mri_mni152", "brainsmall")
CONFIGS = [
    ("local", 1, "inline", None),
    ("local", 2, "process", None),
    ("local", 2, "thread", None),
    ("dask LocalCluster", 2, "processes", "local"),
]


def make_folder(folder: Path, names, copies: int) -> list[tuple[str, tuple, str]]:
    made = []
    for name in names:
        a, spacing, _ = datasets.load(name)
        for k in range(copies):
            p = folder / name / f"copy{k}.npy"
            p.parent.mkdir(parents=True, exist_ok=True)
            np.save(p, a)
        made.append((name, a.shape, str(a.dtype)))
    return made


def digests(report) -> dict[str, str]:
    out = {}
    for f in report["files"]:
        out[
            os.path.basename(os.path.dirname(f["output"])) + "/" + os.path.basename(f["output"])
        ] = hashlib.sha256(Path(f["output"]).read_bytes()).hexdigest()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=3)
    ap.add_argument(
        "--repeat", type=int, default=3, help="runs per configuration; the best is kept"
    )
    ap.add_argument("--names", default=",".join(DEFAULT_NAMES))
    ap.add_argument("--out", default=str(HERE.parent / "results" / "batch"))
    args = ap.parse_args()
    names = [n for n in args.names.split(",") if n in datasets.names()]
    if not names:
        sys.exit("no dataset in the cache; run scripts/fetch_data.py first")
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="volpack-bench-batch-") as tmp:
        src = Path(tmp) / "in"
        made = make_folder(src, names, args.copies)
        api.compress_array(np.zeros((8, 8, 8), np.int16))  # kernels ready in this process
        reference = None
        for label, workers, executor, scheduler in CONFIGS:
            best = None
            for rep in range(args.repeat):
                dst = Path(tmp) / f"out-{len(rows)}-{rep}"
                tasks = batch.plan(str(src), str(dst))
                kw = {"scheduler": scheduler} if scheduler else {"executor": executor}
                report = batch.run(tasks, workers=workers, **kw)
                secs = [round(report["totals"]["seconds"], 2)]
                if best is None or report["totals"]["seconds"] < best["totals"]["seconds"]:
                    best = report
                print(label, executor, workers, "run", rep, secs, flush=True)
            report = best
            t = report["totals"]
            assert t["ok"] == len(tasks), [f["error"] for f in report["files"] if f["error"]]
            d = digests(report)
            reference = reference or d
            rows.append(
                {
                    "where": label,
                    "executor": executor,
                    "workers": workers,
                    "files": t["files"],
                    "raw_mb": round(t["raw_nbytes"] / 1e6, 2),
                    "ratio": round(t["ratio"], 3),
                    "seconds": round(t["seconds"], 2),
                    "files_per_s": round(t["files_per_s"], 2),
                    "mb_per_s": round(t["mb_per_s"], 1),
                    "same_bytes": d == reference,
                }
            )
            print(rows[-1], flush=True)
    with open(out_dir / "batch.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    cols = list(rows[0])
    what = ", ".join(f"{n} {'x'.join(map(str, s))} {dt}" for n, s, dt in made)
    lines = [
        "# Batch compression throughput",
        "",
        f"{rows[0]['files']} files ({what}; "
        f"{args.copies} copies each), lossless, every output decoded and compared; best of "
        f"{args.repeat} runs per row (the machine is shared, single runs vary by 2x). "
        f"Machine: {platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}.",
        "Times are wall clock as a user sees them: worker processes (pool or Dask) load the",
        "compiled kernels from the disk cache, and the Dask row includes starting the",
        "LocalCluster (scheduler and two worker processes, about 2-3 s here).",
        "",
        "| " + " | ".join(cols) + " |",
        "|" + "|".join("---" for _ in cols) + "|",
    ]
    lines += ["| " + " | ".join(str(r[c]) for c in cols) + " |" for r in rows]
    (out_dir / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
