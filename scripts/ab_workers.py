"""One worker against two, for two checkouts of volpack side by side: CPU seconds.

On a shared machine wall-clock speed-ups swing with the load, so this measures what two
workers cost in CPU seconds against one, for a base checkout (``--base``) and the current
one, each in a process of its own kept alive for the whole run; the driver asks them in
turn for the same decode (one worker, two workers, one worker with the time outside the
codec's nogil kernels counted), the order flipped every round, so a burst of load hits
both alike. ``--pin`` runs every decode on one CPU: two workers then never run at once,
and what they cost over one is the software's own (thread hand-offs, GIL waits), not the
cores slowing each other. Blobs are the ``NAME.fast.vpk`` files in ``--blobs``
(``scripts/bench_workers.py --blobs`` writes them).

    python scripts/ab_workers.py --base /tmp/main_checkout mri_mni152 ct_head --repeat 15
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

KERNELS = ("_head_kernel", "_decode_kernel", "tables_kernel", "_palette_kernel")


def serve(blobs: Path, pin: bool) -> None:
    """The worker: read ``NAME WHAT K`` lines, decode, print ``[cpu, wall, outside]``."""
    from volpack import api
    from volpack.volume_codec import fastpredict as fp

    cpus = os.sched_getaffinity(0)
    if pin:
        os.sched_setaffinity(0, {min(cpus)})
    inside = [0.0]

    def timed(f):
        def g(*a):
            t = time.thread_time()
            r = f(*a)
            inside[0] += time.thread_time() - t
            return r

        return g

    kernels = {k: getattr(fp, k) for k in KERNELS if hasattr(fp, k)}
    cache: dict[str, bytes] = {}
    for line in sys.stdin:
        name, what, k = line.split()
        blob = cache.get(name)
        if blob is None:
            blob = cache[name] = (blobs / f"{name}.fast.vpk").read_bytes()
            for w in (1, 2):
                api.decompress_array(blob, workers=w)
        if what == "outside":  # kernels called from Python only (the old decoder's too)
            for n, f in kernels.items():
                setattr(fp, n, timed(f))
            inside[0] = 0.0
        c, w = time.process_time(), time.perf_counter()
        api.decompress_array(blob, workers=int(k))
        c, w = time.process_time() - c, time.perf_counter() - w
        for n, f in kernels.items():
            setattr(fp, n, f)
        print(json.dumps([c, w, c - inside[0] if what == "outside" else 0.0]), flush=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("datasets", nargs="+")
    ap.add_argument("--base", type=Path, required=True, help="a checkout with volpack/")
    ap.add_argument("--blobs", type=Path, default=Path("/tmp/volpack_bench_workers"))
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--pin", action="store_true")
    ap.add_argument("--serve", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args(argv)
    if args.serve:
        serve(args.blobs, args.pin)
        return 0
    trees = {"base": args.base.resolve(), "current": HERE.parent}
    cmd = [sys.executable, __file__, "--serve", "--base", ".", "--blobs", str(args.blobs), "x"]
    procs = {
        t: subprocess.Popen(
            cmd + (["--pin"] if args.pin else []), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            text=True, env=dict(os.environ, PYTHONPATH=str(p)),
        )  # fmt: skip
        for t, p in trees.items()
    }

    def ask(t, name, what, k):
        procs[t].stdin.write(f"{name} {what} {k}\n")
        procs[t].stdin.flush()
        return json.loads(procs[t].stdout.readline())

    from volpack.format.container import Reader

    rows = []
    for name in args.datasets:
        with Reader((args.blobs / f"{name}.fast.vpk").read_bytes()) as r:
            nb = len(r.entries)
        confs = [(t, what, k) for t in trees for what, k in (("cpu", 1), ("cpu", 2), ("outside", 1))]
        res: dict = {c: [] for c in confs}
        load0 = os.getloadavg()[0]
        for i in range(args.repeat):
            for c in confs if i % 2 == 0 else confs[::-1]:
                res[c].append(ask(*c[:1], name, *c[1:]))
        for t in trees:
            c1, c2 = ([x[0] for x in res[(t, "cpu", k)]] for k in (1, 2))
            w1, w2 = ([x[1] for x in res[(t, "cpu", k)]] for k in (1, 2))
            out = min(x[2] for x in res[(t, "outside", 1)])
            rows.append({
                "tree": t, "dataset": name, "bricks": nb, "pinned": int(args.pin),
                "cpu1_best_ms": round(1e3 * min(c1), 1), "cpu2_best_ms": round(1e3 * min(c2), 1),
                "cpu2_over_cpu1_best": round(min(c2) / min(c1), 3),
                "cpu2_over_cpu1_median": round(statistics.median(c2) / statistics.median(c1), 3),
                "outside_kernels_us_per_brick": round(1e6 * out / nb),
                "wall_speedup_best": round(min(w1) / min(w2), 3),
                "load": f"{load0:.1f}-{os.getloadavg()[0]:.1f}",
            })  # fmt: skip
            print(rows[-1], flush=True)
    for p in procs.values():
        p.stdin.close()
        p.wait()
    if args.out:
        from bench_workers import append_csv

        append_csv(rows, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
