"""Two workers against one: wall and CPU seconds of ``api.decompress_array``.

For each volume and codec the blob is encoded once (kept in ``--blobs`` so a later run
decodes the same bytes); then one worker and two workers are run alternately
``--repeat`` times (the order flipped every round) and the best and median of each are
kept. Beside the wall-clock speed-up it reports what says how the work splits when the
machine is shared: the CPU seconds two workers spend against one (extra CPU is work
added by running in parallel), and the share of one worker's CPU spent in the brick
decoders (the rest runs in the main thread whatever the worker count: Amdahl's serial
part), and the CPU seconds of one decode in each of two processes decoding at once over
one process alone (above 1: the two cores slow each other down, shared core, cache or
memory, with no thread, GIL or hand-off of ours involved).

    python scripts/bench_workers.py ct_head mri_ch2better --codecs fast,default --repeat 9
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

CODECS = {"default": {}, "fast": {"codec": "fast"}}


def _run(blob: bytes, workers: int):
    from volpack import api

    w, c = time.perf_counter(), time.process_time()
    out = api.decompress_array(blob, workers=workers)
    return time.perf_counter() - w, time.process_time() - c, out


def decoder_share(blob: bytes) -> float:
    """One worker's CPU seconds spent inside the brick decoders over its total."""
    from volpack.volume_codec import codec as _codec  # noqa: F401  (registry import)
    from volpack.volume_codec import stream

    inside = [0.0]
    orig = stream.get_codec

    def wrapped(cfg):
        c = orig(cfg)

        class Timed:
            def decode_into(self, payload, out):
                t = time.thread_time()
                c.decode_into(payload, out)
                inside[0] += time.thread_time() - t

            def decode(self, payload, shape, dtype):
                t = time.thread_time()
                r = c.decode(payload, shape, dtype)
                inside[0] += time.thread_time() - t
                return r

        return Timed()

    stream.get_codec = wrapped
    try:
        best = float("inf")
        for _ in range(3):
            inside[0] = 0.0
            t = time.process_time()
            from volpack import api

            api.decompress_array(blob, workers=1)
            total = time.process_time() - t
            best = min(best, total)
            share = inside[0] / total
    finally:
        stream.get_codec = orig
    return share


_CHILD = """
import sys, time
from volpack import api
blob = open(sys.argv[1], "rb").read()
api.decompress_array(blob, workers=1)
print("ready", flush=True)
for line in sys.stdin:
    t = time.process_time()
    api.decompress_array(blob, workers=1)
    print(time.process_time() - t, flush=True)
"""


def two_processes(path: Path, repeat: int) -> float:
    """CPU seconds of a one-worker decode in each of two processes started together over
    one process decoding alone (best of ``repeat`` each, alternated)."""
    import subprocess

    procs = [
        subprocess.Popen(
            [sys.executable, "-c", _CHILD, str(path)], stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, text=True,
        )  # fmt: skip
        for _ in range(2)
    ]
    try:
        for p in procs:
            p.stdout.readline()
        alone, both = [], []
        for i in range(repeat):
            for together in (i % 2 == 0, i % 2 != 0):
                run = procs if together else procs[:1]
                for p in run:
                    p.stdin.write("go\n")
                    p.stdin.flush()
                times = [float(p.stdout.readline()) for p in run]
                (both if together else alone).extend(times)
    finally:
        for p in procs:
            p.stdin.close()
            p.wait()
    return min(both) / min(alone)


def brick_costs(blob: bytes) -> list[tuple[float, int]]:
    """Each brick's decode CPU seconds (``decode_into`` alone, best of 3) and payload
    bytes, in file order."""
    from volpack.format.container import Reader
    from volpack.volume_codec import bricks
    from volpack.volume_codec.registry import get_codec

    with Reader(blob) as r:
        c = get_codec(r.header["codec"])
        shape, brick = tuple(r.header["shape"]), tuple(r.header["brick"])
        out = np.empty(shape, np.dtype(r.header["dtype"]))
        costs = []
        for e in r.entries:
            p = r.read(e.t, e.node)
            view = out[bricks.brick_slices(shape, brick, e.node)]
            best = float("inf")
            for _ in range(3):
                t = time.thread_time()
                c.decode_into(p, view)
                best = min(best, time.thread_time() - t)
            costs.append((best, e.nbytes))
    return costs


def makespan(costs: list[float], workers: int, ahead: int | None) -> float:
    """When the last of ``costs`` ends on ``workers`` greedy workers taking items in list
    order; ``ahead``: the in-order map's bound (an item is submitted only when fewer
    than ``ahead * workers`` are pending counting from the oldest not yet handed back),
    None: the as-completed map (no such wait)."""
    free = [0.0] * workers
    ends: list[float] = []
    for k, c in enumerate(costs):
        start = min(free)
        if ahead is not None and k >= ahead * workers:
            start = max(start, max(ends[: k - ahead * workers + 1]))  # in-order hand-back
        w = free.index(min(free))
        free[w] = start + c
        ends.append(free[w])
    return max(free)


def modelled(costs: list[tuple[float, int]]) -> tuple[float, float]:
    """Two workers' modelled speed-up with the old schedule (file order, in-order map
    of look-ahead 4) and the new one (largest payload first, as completed)."""
    t = [c for c, _ in costs]
    lpt = [c for c, _ in sorted(costs, key=lambda x: -x[1])]
    return sum(t) / makespan(t, 2, 4), sum(t) / makespan(lpt, 2, None)


def measure(name, a, codec, repeat, blobs: Path):
    from volpack import api

    path = blobs / f"{name}.{codec}.vpk"
    if path.exists():
        blob = path.read_bytes()
    else:
        blob = api.compress_array(a, **CODECS[codec])
        path.write_bytes(blob)
    for k in (1, 2):
        if not np.array_equal(api.decompress_array(blob, workers=k), a):
            raise AssertionError(f"{name}: {k} workers did not round-trip")
    res = {1: [], 2: []}
    loads = [os.getloadavg()[0]]
    for i in range(repeat):
        for k in ((1, 2) if i % 2 == 0 else (2, 1)):
            w, c, _ = _run(blob, k)
            res[k].append((w, c))
    loads.append(os.getloadavg()[0])
    w1 = [w for w, _ in res[1]]
    w2 = [w for w, _ in res[2]]
    c1 = [c for _, c in res[1]]
    c2 = [c for _, c in res[2]]
    from volpack.format.container import Reader

    with Reader(blob) as r:
        nb = len(r.entries)
    return {
        "codec": codec,
        "dataset": name,
        "bricks": nb,
        "mb": round(a.nbytes / 1e6, 2),
        "wall1_best_ms": round(1e3 * min(w1), 1),
        "wall2_best_ms": round(1e3 * min(w2), 1),
        "speedup_best": round(min(w1) / min(w2), 3),
        "speedup_median": round(statistics.median(w1) / statistics.median(w2), 3),
        "cpu2_over_cpu1": round(min(c2) / min(c1), 3),
        "decoder_share_1": round(decoder_share(blob), 3),
        "cpu_2proc_over_1": round(two_processes(path, repeat), 3),
        **dict(zip(("model_in_order", "model_largest_first"), map(lambda x: round(x, 3), modelled(brick_costs(blob))))),
        "load": f"{min(loads):.1f}-{max(loads):.1f}",
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--codecs", default="fast,default")
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--label", default="")
    ap.add_argument("--blobs", type=Path, default=Path("/tmp/volpack_bench_workers"))
    ap.add_argument("--out", type=Path, default=HERE.parent / "results" / "lossless" / "workers")
    args = ap.parse_args(argv)
    import datasets

    args.blobs.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.datasets:
        a, _, _ = datasets.load(name)
        a = np.ascontiguousarray(a)
        for codec in args.codecs.split(","):
            row = {"label": args.label, **measure(name, a, codec, args.repeat, args.blobs)}
            print(row, flush=True)
            rows.append(row)
    append_csv(rows, args.out / "two_workers.csv")
    return 0


def append_csv(rows: list[dict], path: Path) -> None:
    """Add ``rows`` to the CSV at ``path`` (its header first when it is new)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, list(rows[0]))
        if new:
            w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    raise SystemExit(main())
