"""tab31: the octree's tabled decoder alone (``decode_tabled_kernel``), base tree against
the branch (its table no longer holds the subtree ends: ``end`` read from the scan).

Chunks: ``--chunks`` 32^3 blocks of Laplace coefficients (scale 3, ``--zeros`` of them
zero, the 16^3 low-pass corner zero), coded once by ``arith.encode`` over the octree's
scan of a chunk (dfs, one lift level). Two worker processes (PYTHONPATH = the tree) take
turns; a turn decodes every chunk once; the least CPU time of ``--rounds`` turns each.

    python results/lossy/tab31/octree_kernel.py --rounds 9
"""

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path


def worker(nchunks: int, zeros: float) -> None:
    import numpy as np

    from volpack.entropy import arith
    from volpack.wavelet.sigmap import scan

    s = scan((32, 32, 32), (1, 1, 1), "dfs")
    tab = arith.context_table(s)
    rng = np.random.default_rng(3)
    chunks = []
    for _ in range(nchunks):
        c = np.rint(rng.laplace(0, 3, (32, 32, 32))).astype(np.int64)
        c[rng.random(c.shape) < zeros] = 0
        c[:16, :16, :16] = 0
        chunks.append((np.frombuffer(arith.encode(c, s), np.uint8), c.reshape(-1)))
    with_end = "end" in arith.decode_tabled_kernel.py_func.__code__.co_varnames[:3]
    flat = np.zeros(32**3, np.int64)

    def run():
        for data, c in chunks:
            flat[:] = 0
            if with_end:
                st = arith.decode_tabled_kernel(data, s.perm, s.end, tab, s.cls, flat, 63)
            else:
                st = arith.decode_tabled_kernel(data, s.perm, tab, s.cls, flat, 63)
            assert st == 0 and np.array_equal(flat, c)

    run()
    print(json.dumps({"with_end": with_end, "bytes": sum(d.size for d, _ in chunks)}), flush=True)
    for _ in sys.stdin:
        t = time.process_time()
        run()
        print(json.dumps(time.process_time() - t), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trees", default="base=/tmp/tab31/base,branch=.")
    ap.add_argument("--chunks", type=int, default=139)
    ap.add_argument("--rounds", type=int, default=9)
    args = ap.parse_args()
    for zeros in (0.5, 0.9):
        procs = {}
        for label, tree in (t.split("=") for t in args.trees.split(",")):
            env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()))
            cmd = [sys.executable, __file__, "--worker", str(args.chunks), str(zeros)]
            p = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                 env=env)  # fmt: skip
            print(label, zeros, p.stdout.readline().strip(), flush=True)
            procs[label] = p
        best = dict.fromkeys(procs, 1e9)
        for r in range(args.rounds):
            for label in list(procs)[:: 1 if r % 2 == 0 else -1]:
                procs[label].stdin.write("go\n")
                procs[label].stdin.flush()
                best[label] = min(best[label], json.loads(procs[label].stdout.readline()))
        ms = {k: round(1e3 * v, 2) for k, v in best.items()}
        print(f"zeros {zeros}: least CPU ms of {args.rounds} turns {ms}", flush=True)
        for p in procs.values():
            p.stdin.close()
            p.wait()


if __name__ == "__main__":
    if "--worker" in sys.argv:
        i = sys.argv.index("--worker")
        worker(int(sys.argv[i + 1]), float(sys.argv[i + 2]))
    else:
        main()
