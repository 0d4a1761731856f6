"""Compile time of every numba kernel on an empty cache: what a first run pays.

Runs ``volpack warmup``'s paths (or ``volpack demo`` with ``--demo``) in a fresh
process with a fresh kernel cache and records numba's compile events. Times are CPU
seconds and exclusive: a kernel's own compilation, without the callees compiled inside it.

    python scripts/compile_times.py                  # results/compile_times.csv, top 25 printed
    python scripts/compile_times.py --demo           # what `volpack demo` compiles
"""

from __future__ import annotations

import argparse
import csv
import os
import pathlib
import sys
import tempfile
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demo", action="store_true", help="run the demo's paths, not warmup's")
    ap.add_argument("--out", default="results/compile_times.csv")
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args()
    os.environ["VOLPACK_CACHE_DIR"] = tempfile.mkdtemp(prefix="volpack-ct-")
    os.environ.pop("NUMBA_CACHE_DIR", None)

    import numba.core.event as ev

    class CpuRecorder(ev.Listener):
        """numba's RecordingListener, timed in process CPU seconds: on a shared machine
        wall time measures the neighbours as much as the compiler."""

        def __init__(self):
            self.buffer = []

        def on_start(self, event):
            self.buffer.append((time.process_time(), event))

        def on_end(self, event):
            self.buffer.append((time.process_time(), event))

    rec = CpuRecorder()
    t0 = time.perf_counter()
    c0 = time.process_time()
    with ev.install_listener("numba:compile", rec):
        if args.demo:
            from volpack.demo import run

            run(tempfile.mkdtemp(prefix="volpack-ct-demo-"), repeat=1)
        else:
            from volpack.warmup import warm

            warm()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0

    # exclusive time per (kernel, signature): subtract the compilations nested inside
    stack: list[list] = []
    rows: dict[tuple[str, str], float] = {}
    for t, e in rec.buffer:
        if e.is_start:
            stack.append([t, 0.0])
            continue
        start, nested = stack.pop()
        total = t - start
        if stack:
            stack[-1][1] += total
        disp = e.data["dispatcher"]
        name = f"{disp.py_func.__module__}.{disp.py_func.__qualname__}"
        sig = ",".join(str(a) for a in e.data["args"])
        rows[(name, sig)] = rows.get((name, sig), 0.0) + total - nested
    out = sorted(((s, n, sig) for (n, sig), s in rows.items()), reverse=True)
    pathlib.Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["seconds", "kernel", "signature"])
        for s, n, sig in out:
            w.writerow([f"{s:.3f}", n, sig])
    per_kernel: dict[str, float] = {}
    for s, n, _ in out:
        per_kernel[n] = per_kernel.get(n, 0.0) + s
    total = sum(s for s, _, _ in out)
    print(
        f"{len(out)} compilations of {len(per_kernel)} kernels: {total:.1f} CPU s compiling, "
        f"{cpu:.1f} CPU s and {wall:.1f} s wall in all ({'demo' if args.demo else 'warmup'})",
        file=sys.stderr,
    )
    for n, s in sorted(per_kernel.items(), key=lambda kv: -kv[1])[: args.top]:
        count = sum(1 for _, k, _ in out if k == n)
        print(f"{s:7.2f} s  {count:3d} sig  {n}")


if __name__ == "__main__":
    main()
