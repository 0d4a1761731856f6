"""Bytes and encode CPU time of two volpack trees on the lossy corpus, interleaved.

Each tree runs in a worker process of its own (PYTHONPATH set to it, one BLAS thread);
the workers take turns (their order alternating), never at once. Per cell (field, bound
relative to its value range) each worker encodes with the default effort, one worker
(api.compress_array), and answers the stream's sha256, length and CPU seconds
(time.process_time); the best of --rounds is kept. A warm-up encode first.

    python results/lossy/mem30/same.py --trees base=/tmp/mem30/base,mem30=. \\
        --fields floats --rels 1e-2,1e-3,1e-4,1e-5 --out results/lossy/mem30/same.csv

--fields: 'floats' (the float fields of scripts/bench_lossy.py), names of
scripts/datasets.py, or .npy paths.
"""

import argparse
import csv
import json
import os
import subprocess
import sys
from pathlib import Path

WORKER = r"""
import hashlib, json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1] + "/scripts")
import volpack
from volpack import api
from datasets import load
print(json.dumps(volpack.__file__), flush=True)
warm = np.cumsum(np.random.default_rng(0).standard_normal((24, 24, 24)), axis=2)
for rel in (1e-2, 1e-5):
    api.compress_array(warm.astype(np.float32), max_error=40 * rel, workers=1)
cache = {}
for line in sys.stdin:
    name, rel = json.loads(line)
    if name not in cache:
        cache.clear()
        cache[name] = np.load(name) if name.endswith(".npy") else load(name)[0]
    x = cache[name]
    e = rel * (float(np.nanmax(x)) - float(np.nanmin(x)))
    t = time.process_time()
    blob = api.compress_array(x, max_error=e, workers=1)
    cpu = time.process_time() - t
    print(json.dumps([hashlib.sha256(blob).hexdigest(), len(blob), cpu]), flush=True)
"""


def start(path):
    env = dict(os.environ, PYTHONPATH=str(Path(path).resolve()), OMP_NUM_THREADS="1",
               OPENBLAS_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1")  # fmt: skip
    p = subprocess.Popen(
        [sys.executable, "-c", WORKER, str(Path(path).resolve())], cwd=path, env=env,
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    print(path, "->", json.loads(p.stdout.readline()), file=sys.stderr, flush=True)
    return p


def ask(p, name, rel):
    p.stdin.write(json.dumps([name, rel]) + "\n")
    p.stdin.flush()
    return json.loads(p.stdout.readline())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trees", required=True)
    ap.add_argument("--fields", default="floats")
    ap.add_argument("--rels", default="1e-2,1e-3,1e-4,1e-5")
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--out", required=True)
    a = ap.parse_args()
    trees = [t.split("=", 1) for t in a.trees.split(",")]
    if a.fields == "floats":
        sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
        from bench_lossy import GROUPS

        names = GROUPS["floats"]
    else:
        names = a.fields.split(",")
    procs = [start(path) for _, path in trees]
    rows = []
    with open(a.out, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["field", "rel"] + [f"{k}_{lab}" for lab, _ in trees for k in ("bytes", "cpu")]
                   + ["same"])  # fmt: skip
        for name in names:
            for rel in (float(r) for r in a.rels.split(",")):
                got = [None] * len(trees)
                for r in range(a.rounds):
                    order = range(len(trees)) if (len(rows) + r) % 2 == 0 else reversed(range(len(trees)))
                    for i in order:
                        sha, n, cpu = ask(procs[i], name, rel)
                        if got[i] is None or cpu < got[i][2]:
                            got[i] = (sha, n, cpu)
                same = len({g[0] for g in got}) == 1
                row = [Path(name).stem, rel] + [v for g in got for v in (g[1], round(g[2], 3))] + [same]
                rows.append(row)
                w.writerow(row)
                f.flush()
                print(*row, file=sys.stderr, flush=True)
    for p in procs:
        p.stdin.close()
        p.wait()
    cpu = [sum(r[3 + 2 * i] for r in rows) for i in range(len(trees))]
    print(f"{len(rows)} cells, {sum(r[-1] for r in rows)} with the same bytes; CPU "
          + ", ".join(f"{lab} {c:.1f} s" for (lab, _), c in zip(trees, cpu)))


if __name__ == "__main__":
    main()
