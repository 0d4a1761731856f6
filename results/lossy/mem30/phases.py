"""Peak memory per phase of one lossy encode (compress_array, one worker, default effort):
the traced peak (tracemalloc: numpy arrays made in Python; arrays a numba kernel makes
itself are not seen) and the resident peak (VmHWM, reset at each phase's start through
/proc/self/clear_refs), both in MB, a phase's peak including what is held when it starts.
The traced memory at the entry of a phase's highest call is shown beside (what it
started on: the scan caches, the brick, the arrays of the paths before). Then what the process still holds after the encode, by line (tracemalloc snapshot).

    PYTHONPATH=. python results/lossy/mem30/phases.py FIELD.npy [--rel 1e-3] [--out CSV]
"""

import argparse
import csv
import functools
import sys
import time
import tracemalloc

import numpy as np

import volpack
from volpack import api
from volpack.volume_codec import bounded_cdf97, lossy

MB = 1e6
PHASES = {  # (owner, attribute) -> phase name
    (lossy.BoundedCodec, "_quantize"): "quantise",
    (lossy.BoundedCodec, "_reconstruct"): "reconstruct",
    (lossy.BoundedCodec, "_interp_candidate"): "interpolation",
    (bounded_cdf97, "plan"): "cdf97 plan",
    (lossy.BoundedCodec, "_coef_candidate"): "coefficients",
    (lossy.BoundedCodec, "_longfit"): "long fit",
    (lossy.BoundedCodec, "_cdf97_candidates"): "cdf97",
    (lossy.BoundedCodec, "_code_quantised"): "quantised voxels",
    (lossy.BoundedCodec, "_finish"): "finish (check)",
}
stack, peaks = [], {}


def hwm():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM"):
            return int(line.split()[1]) * 1024
    return 0


def reset():
    tracemalloc.reset_peak()
    with open("/proc/self/clear_refs", "w") as f:
        f.write("5")


def now():
    return tracemalloc.get_traced_memory()[1], hwm()


def wrap(name, fn):
    @functools.wraps(fn)
    def run(*a, **k):
        if stack:  # fold the outer phase's peak so far into its record
            t, r = now()
            stack[-1] = (max(stack[-1][0], t), max(stack[-1][1], r))
        reset()
        held = tracemalloc.get_traced_memory()[0]
        stack.append(now())
        try:
            return fn(*a, **k)
        finally:
            t, r = now()
            t, r = max(stack[-1][0], t), max(stack[-1][1], r)
            stack.pop()
            old = peaks.get(name, (0, 0, 0, 0))
            top = (t, held) if t > old[0] else (old[0], old[3])
            peaks[name] = (top[0], max(old[1], r), old[2] + 1, top[1])
            if stack:
                stack[-1] = (max(stack[-1][0], t), max(stack[-1][1], r))
            reset()

    return run


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("field")
    ap.add_argument("--rel", type=float, default=1e-3)
    ap.add_argument("--out")
    a = ap.parse_args()
    print(volpack.__file__, file=sys.stderr)
    x = np.load(a.field)
    e = a.rel * float(x.max() - x.min())
    warm = np.cumsum(np.random.default_rng(0).standard_normal((24, 24, 24)), axis=2)
    api.compress_array(warm.astype(np.float32), max_error=40 * a.rel)  # compile first
    for (owner, attr), name in PHASES.items():
        setattr(owner, attr, wrap(name, getattr(owner, attr)))
    tracemalloc.start(8)
    base = tracemalloc.get_traced_memory()[0]
    t0 = time.process_time()
    blob = wrap("compress_array (all)", api.compress_array)(x, max_error=e, workers=1)
    cpu = time.process_time() - t0
    held = tracemalloc.take_snapshot()
    print(f"{a.field} rel {a.rel}: {len(blob)} bytes, {cpu:.1f} s CPU (traced), volume "
          f"{x.nbytes / MB:.1f} MB, traced before {base / MB:.1f} MB")
    rows = [
        (n, round(t / MB, 1), round(h / MB, 1), round(r / MB, 1), c)
        for n, (t, r, c, h) in peaks.items()
    ]
    print(f"{'phase':24} {'traced MB':>10} {'at entry':>9} {'RSS MB':>8} calls")
    for row in rows:
        print(f"{row[0]:24} {row[1]:10.1f} {row[2]:9.1f} {row[3]:8.1f} {row[4]:5d}")
    print("held after the encode, by line (top 8):")
    for s in held.statistics("lineno")[:8]:
        print(f"  {s.size / MB:8.1f} MB  {s.traceback}")
    if a.out:
        with open(a.out, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["phase", "traced_peak_mb", "traced_at_entry_mb", "rss_peak_mb", "calls"])
            w.writerows(rows)


if __name__ == "__main__":
    main()
