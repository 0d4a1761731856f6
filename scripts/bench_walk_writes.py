"""The node writes of a walk's first frame on their own: ``ResidentVolume.update`` with
every chunk already decoded, source trees alternating in fresh processes.

Each process runs ``volpack walk T.vpk OUT/ --orbit 1`` to learn frame 0's selection,
then writes it into a new resident grid ``--repeat`` times on ``--workers`` threads
(the chunks stay in the tree's cache, so only the writes and the grid's set-up are
timed): the update's process CPU and the writes' thread CPU (``Octree.resampled``,
summed over the threads), least and median, and a hash of the grid (equal across
trees: the same bytes).

    python scripts/bench_walk_writes.py o.vpk --trees /tmp/main . --rounds 2
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

CHILD = r"""
import contextlib, hashlib, io, statistics, sys, tempfile, threading, time
from volpack.cli import main as cli
from volpack.octree import reader
from volpack.render import resident
vpk, workers, repeat = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
cap = {}
upd = resident.ResidentVolume.update
def rec(self, selection, fill, w=1):
    cap.setdefault("args", (self, list(selection), fill))
    return upd(self, selection, fill, w)
resident.ResidentVolume.update = rec
with contextlib.redirect_stdout(io.StringIO()):
    cli(["walk", vpk, tempfile.mkdtemp() + "/", "--orbit", "1"], standalone_mode=False)
resident.ResidentVolume.update = upd
rv0, sel, fill = cap["args"]
lock, acc = threading.Lock(), [0.0]
rs = reader.Octree.resampled
def timed(*a, **k):
    t = time.thread_time()
    try:
        return rs(*a, **k)
    finally:
        with lock:
            acc[0] += time.thread_time() - t
reader.Octree.resampled = timed
upd_ms, writes_ms = [], []
for _ in range(repeat):
    rv = resident.ResidentVolume(rv0.tree, rv0.value_range)
    acc[0] = 0.0
    c = time.process_time()
    rv.update(sel, fill, workers)
    upd_ms.append(1e3 * (time.process_time() - c))
    writes_ms.append(1e3 * acc[0])
h = hashlib.sha256(rv.prep.data.tobytes()).hexdigest()[:16]
print(f"update CPU {min(upd_ms):.0f} / {statistics.median(upd_ms):.0f} ms, writes thread CPU "
      f"{min(writes_ms):.0f} / {statistics.median(writes_ms):.0f} ms (least / median of "
      f"{repeat}), grid {h}")
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--trees", nargs="+", required=True)
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=12)
    ap.add_argument("--workers", type=int, default=1)
    args = ap.parse_args(argv)
    for rnd in range(args.rounds):
        for tree in args.trees:
            env = dict(os.environ, PYTHONPATH=tree)
            p = subprocess.run([sys.executable, "-c", CHILD, args.vpk, str(args.workers),
                                str(args.repeat)], env=env, capture_output=True, text=True,
                               cwd="/tmp")  # fmt: skip
            if p.returncode:
                raise SystemExit(p.stderr[-2000:])
            print(f"round {rnd} {tree} workers {args.workers}: {p.stdout.strip()}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
