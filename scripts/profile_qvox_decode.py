"""Where a decode of quantised voxels by the fast codec (``--effort fast``) spends its
time, in ns a voxel: the fast codec's kernel (``fastpredict.decode``: head and walk), the
rest of the fast payload's decode (main: the copy of its work array into the quantised
brick), the rebuilding of the voxels (dequantisation, palette look-up), the corrections,
the rest of the brick payload, and the rest of the whole decode (container, checks,
Python; its best time less the brick's best), beside SZ3's decode of the same cell.

Each cell is encoded once; then ``--rounds`` whole decodes (``api.decompress_array``),
SZ3's interleaved with them, each timed in CPU seconds, the best kept; the stage timers
(wrapped functions) are read over a further ``--rounds`` decodes (each stage's best).

    python scripts/profile_qvox_decode.py --cells mecca_t:1e-2,seam_ps:1e-2 --rounds 20
"""

from __future__ import annotations

import argparse
import collections
import csv
import functools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


class Timers:
    def __init__(self):
        self.acc = collections.defaultdict(float)
        self.depth = collections.defaultdict(int)

    def wrap(self, owner, name, stage):
        fn = getattr(owner, name)

        @functools.wraps(fn)
        def run(*args, **kwargs):
            if self.depth[stage]:
                return fn(*args, **kwargs)
            self.depth[stage] += 1
            t0 = time.perf_counter()
            try:
                return fn(*args, **kwargs)
            finally:
                self.acc[stage] += time.perf_counter() - t0
                self.depth[stage] -= 1

        setattr(owner, name, run)


STAGES = ("kernel", "fast_decode", "rebuild", "corrections", "brick")


def install(t: Timers) -> None:
    """Wrap the stage functions of the tree on the path: the fast codec's kernel
    (``fastpredict.decode``, head and walk into its work array); the fast payload's
    decode around it (main: ``FastCodec.decode``, the work array copied, or looked up
    through the palette, into a ``qdtype`` brick; since qvox26: ``fast.decode_parts``,
    no copy); the rebuilding of the voxels (the dequantisation kernels, and since qvox26
    the palette's table look-up into the volume); the corrections; the brick payload."""
    from volpack.volume_codec import fast, fastpredict, floatcast, lossy

    t.wrap(fastpredict, "decode", "kernel")
    if hasattr(fast, "decode_parts"):
        t.wrap(fast, "decode_parts", "fast_decode")
        t.wrap(fastpredict, "store_palette", "rebuild")
    else:
        t.wrap(fast.FastCodec, "decode", "fast_decode")
    t.wrap(floatcast, "dequantise_float32", "rebuild")
    t.wrap(floatcast, "dequantise_integer", "rebuild")
    t.wrap(lossy, "apply_corrections", "corrections")
    t.wrap(lossy.BoundedCodec, "_decode", "brick")  # the whole brick payload


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--cells", required=True, help="name:rel,name:rel,...")
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--label", default="")
    ap.add_argument("--out", default=None, help="append rows to this CSV")
    args = ap.parse_args()
    from pysz import sz, szConfig, szErrorBoundMode

    from volpack import api

    timers = Timers()
    install(timers)
    rows = []
    cache = {}
    for cell in args.cells.split(","):
        name, rel = cell.split(":")
        rel = float(rel)
        if name not in cache:
            a, _s, _d = datasets.load(name)
            cache = {name: np.ascontiguousarray(a)}
        a = cache[name]
        vrange = float(a.max()) - float(a.min())
        e = float(f"{vrange * rel:.4g}")
        blob = api.compress_array(a, max_error=e, effort="fast")
        conf = szConfig(a.shape)
        conf.errorBoundMode = szErrorBoundMode.ABS
        conf.absErrorBound = e
        zblob = sz.compress(a, conf)[0]
        calls = {
            "volpack": lambda blob=blob: api.decompress_array(blob),
            "sz3": lambda z=zblob, a=a: sz.decompress(z, a.dtype, a.shape)[0],
        }
        out = calls["volpack"]()
        assert np.abs(out.astype(np.float64) - a).max() <= e
        best = {k: float("inf") for k in calls}
        for r in range(args.rounds):
            for k in ("volpack", "sz3") if r % 2 else ("sz3", "volpack"):
                t0 = time.process_time()
                calls[k]()
                best[k] = min(best[k], time.process_time() - t0)
        low = dict.fromkeys(STAGES, float("inf"))
        for _ in range(args.rounds):  # each stage's best over the rounds (means took outliers)
            timers.acc.clear()
            calls["volpack"]()
            low = {s: min(low[s], timers.acc[s]) for s in STAGES}
        n = a.size
        ns = {s: 1e9 * low[s] / n for s in STAGES}
        row = {
            "label": args.label,
            "dataset": name,
            "rel": rel,
            "voxels": n,
            "ratio": round(a.nbytes / len(blob), 3),
            "ns_total": round(1e9 * best["volpack"] / n, 3),
            "ns_sz3": round(1e9 * best["sz3"] / n, 3),
            "x_sz3": round(best["sz3"] / best["volpack"], 3),
            "ns_kernel": round(ns["kernel"], 3),
            "ns_fast_rest": round(ns["fast_decode"] - ns["kernel"], 3),
            "ns_rebuild": round(ns["rebuild"], 3),
            "ns_corrections": round(ns["corrections"], 3),
            "ns_brick_other": round(
                ns["brick"] - ns["fast_decode"] - ns["rebuild"] - ns["corrections"], 3
            ),
            "ns_outside_brick": round(1e9 * best["volpack"] / n - ns["brick"], 3),
        }
        rows.append(row)
        print(" ".join(f"{k} {v}" for k, v in row.items()), flush=True)
    if args.out:
        path = Path(args.out)
        new = not path.exists()
        with path.open("a", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            if new:
                w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
