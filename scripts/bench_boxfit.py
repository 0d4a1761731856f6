"""The float box fit's encoder (``effort="max"``) before and after, in one process: the
``fit`` and ``fit_box`` of an older tree's ``floatfit.py`` (loaded beside this tree's, the
rest of the codec shared) against this tree's, ``api.compress_array(a, effort="max", workers=1)``
timed in CPU seconds with the two alternating, best of ``--repeat``; the files compared
byte for byte and decoded bit for bit; the peak traced memory (tracemalloc) of one more
encode each. With ``--default-box``, also what the box would cost and give in the
default: version 8 with the box shapes tried (``lossless.BOX_VERSION`` lowered to 8 for
the run) against version 8.

    python scripts/bench_boxfit.py cam_u tgv_u --before /tmp/base22 --repeat 3 \\
        --out results/lossless/boxfast22/ab.csv

The load average is written with each row (two cores shared with other work).
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import os
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def cpu(fn):
    t = time.process_time()
    out = fn()
    return time.process_time() - t, out


def old_fits(tree: Path):
    """``fit`` and ``fit_box`` of ``tree``'s ``floatfit.py``, as a module of this tree's
    package."""
    name = "volpack.volume_codec.floatfit_before"
    spec = importlib.util.spec_from_file_location(
        name, tree / "volpack" / "volume_codec" / "floatfit.py"
    )
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod.fit, mod.fit_box


def traced_peak(fn) -> float:
    tracemalloc.start()
    try:
        fn()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def main(argv: list[str] | None = None) -> int:
    from volpack import api
    from volpack.volume_codec import floatfit as ff
    from volpack.volume_codec import lossless

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("datasets", nargs="+", metavar="NAME")
    ap.add_argument("--before", type=Path, required=True, help="the older source tree")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--blas-threads", type=int, default=0, help="0: the library's default")
    ap.add_argument("--default-box", action="store_true")
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args(argv)
    if args.blas_threads:
        from threadpoolctl import threadpool_limits

        threadpool_limits(args.blas_threads)
    fits = {"before": old_fits(args.before), "after": (ff.fit, ff.fit_box)}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    new_file = not args.out.exists()
    with open(args.out, "a", newline="") as fh:
        out = csv.writer(fh)
        if new_file:
            out.writerow(["dataset", "shape", "mb", "variant", "bytes", "cpu_s_best", "cpu_s_all",
                          "mb_s", "traced_peak_mb", "blas_threads", "load"])  # fmt: skip
        for name in args.datasets:
            a = datasets.load(name)[0]
            mb = a.nbytes / 1e6
            api.compress_array(a[:6, :24, :24].copy(), effort="max", workers=1)  # compile
            runs = {
                "before": lambda: api.compress_array(a, effort="max", workers=1),
                "after": lambda: api.compress_array(a, effort="max", workers=1),
            }
            if args.default_box:
                runs["v8"] = lambda: api.compress_array(a, predict_version=8, workers=1)
                runs["v8+box"] = lambda: api.compress_array(a, predict_version=8, workers=1)
            times = {k: [] for k in runs}
            blobs, peaks = {}, {}

            def setup(k):
                ff.fit, ff.fit_box = fits["before"] if k == "before" else fits["after"]
                lossless.BOX_VERSION = 8 if k == "v8+box" else 10

            try:
                for _ in range(args.repeat):
                    for k, fn in runs.items():
                        setup(k)
                        t, blobs[k] = cpu(fn)
                        times[k].append(t)
                for k, fn in runs.items():
                    setup(k)
                    peaks[k] = traced_peak(fn)
            finally:
                setup("after")
            for k, blob in blobs.items():
                got = api.decompress_array(blob, workers=1)
                if not np.array_equal(got.view(f"u{a.itemsize}"), a.view(f"u{a.itemsize}")):
                    raise AssertionError(f"{name} {k}: not bit exact")
            load = os.getloadavg()[0]
            for k in runs:
                best = min(times[k])
                out.writerow([name, "x".join(map(str, a.shape)), f"{mb:.3f}", k, len(blobs[k]),
                              f"{best:.3f}", " ".join(f"{t:.3f}" for t in times[k]),
                              f"{mb / best:.3f}", f"{peaks[k]:.1f}", args.blas_threads,
                              f"{load:.1f}"])  # fmt: skip
            fh.flush()
            line = " ".join(
                f"{k} {len(blobs[k])} B {min(times[k]):.2f} s ({mb / min(times[k]):.2f} MB/s, "
                f"{peaks[k]:.0f} MB);"
                for k in runs
            )
            print(f"{name}: {line} load {load:.1f}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
