"""Where the float box fit's encoder (``effort="max"``, predict_version 10) spends its
time: CPU and wall seconds of each stage of ``api.compress_array(a, effort="max",
workers=1)``, by wrapping :mod:`volpack.volume_codec.floatfit`'s functions with timers
(their own time, callees subtracted).

    python scripts/profile_boxfit.py cam_u tgv_u cam_t14 xray_1jzv --blas-threads 1 \
        --out results/lossless/boxfast22/stages.csv

Stages: ``fit`` (the 23 weights), ``fit_box`` (the box's normal equations, residuals,
trimmed refit, less the two below), ``rows`` (building row matrices: the 23-weight
fit's before session 22, both fits' after), ``solve``
(``_solve``), ``encode:<variant>`` (the residual coding of one stream), ``other``
(everything else: Lorenzo, lattice, blend, zstd, the container).
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402
import numpy as np  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    from volpack import api
    from volpack.volume_codec import floatfit as ff

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+", metavar="NAME", help="a dataset or a .npy file")
    parser.add_argument("--blas-threads", type=int, default=0, help="0: the library's default")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    if args.blas_threads:
        from threadpoolctl import threadpool_limits

        threadpool_limits(args.blas_threads)
    cpu_t, wall_t = defaultdict(float), defaultdict(float)
    stack = []  # (name, cpu at entry, wall at entry, callee cpu, callee wall)

    def timed(name_of, fn):
        def run(*a, **k):
            stack.append([name_of(a, k), time.process_time(), time.perf_counter(), 0.0, 0.0])
            try:
                return fn(*a, **k)
            finally:
                name, c0, w0, cc, cw = stack.pop()
                c, w = time.process_time() - c0, time.perf_counter() - w0
                cpu_t[name] += c - cc
                wall_t[name] += w - cw
                if stack:
                    stack[-1][3] += c
                    stack[-1][4] += w

        return run

    def variant(a, k):
        box = a[3] if len(a) > 3 else k.get("box")
        if box is not None:
            return "encode:box%dx%dx%d" % box[0]
        return "encode:fit" if (len(a) > 2 and a[2] is not None) else "encode:lorenzo"

    ff.fit = timed(lambda a, k: "fit", ff.fit)
    ff.fit_box = timed(lambda a, k: "fit_box", ff.fit_box)
    rows_fn = "fit_rows" if hasattr(ff, "fit_rows") else "_rows"  # (the tree before: _rows)
    setattr(ff, rows_fn, timed(lambda a, k: "rows", getattr(ff, rows_fn)))
    ff._solve = timed(lambda a, k: "solve", ff._solve)
    ff.encode = timed(variant, ff.encode)
    rows = []
    for name in args.datasets:
        a = np.load(name) if name.endswith(".npy") else datasets.load(name)[0]
        api.compress_array(a[:8, :32, :32].copy(), effort="max", workers=1)  # compile
        cpu_t.clear()
        wall_t.clear()
        c0, w0 = time.process_time(), time.perf_counter()
        blob = api.compress_array(a, effort="max", workers=1)
        c, w = time.process_time() - c0, time.perf_counter() - w0
        cpu_t["other"] = c - sum(cpu_t.values())
        wall_t["other"] = w - sum(wall_t.values())
        load = os.getloadavg()[0]
        print(f"{name} {a.shape} {len(blob)} bytes: {c:.2f} CPU s, {w:.2f} s, "
              f"{a.nbytes / 1e6 / c:.3f} MB/s a core, load {load:.1f}")  # fmt: skip
        for stage in sorted(cpu_t, key=cpu_t.get, reverse=True):
            print(f"  {stage:20s} {cpu_t[stage]:7.3f} CPU s {wall_t[stage]:7.3f} s")
            rows.append([name, len(blob), stage, f"{cpu_t[stage]:.3f}", f"{wall_t[stage]:.3f}",
                         args.blas_threads, f"{load:.1f}"])  # fmt: skip
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with open(args.out, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["dataset", "bytes", "stage", "cpu_s", "wall_s", "blas_threads", "load"])
            out.writerows(rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
