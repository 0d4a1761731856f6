"""Decode speed of two volpack trees on the same default-effort streams, with SZ3 beside.

Each tree runs in a worker process of its own (PYTHONPATH set to the tree); the workers
take turns, never at once. Per cell (a field of cells.py at a bound relative to its
range) each worker decodes the stored stream (cells.blob, made once by the base code)
and SZ3's stream of the field (pysz, its defaults, made in the worker) in rotating
order, ``--inner`` decodes of each a turn, ``--rounds`` turns; CPU seconds of the
worker's own process, best kept. The figures: the branch's speed over the base's
(``speedup``) and each tree's over SZ3's measured in the same process (``x_sz3``).
``same``: the two trees decoded the same bits.

    python results/lossy/ldec31/ab.py --trees base=/tmp/ldec31/base,branch=. \\
        --fields climate_t,tgv128 --rounds 5 --out results/lossy/ldec31/ab_tune.csv
"""

import argparse
import csv
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def worker() -> None:
    sys.path.insert(0, str(HERE))
    import cells
    import numpy as np

    import volpack
    from volpack import api, peers

    sz3 = peers.sz3_encoder()
    cell = {}
    print(json.dumps({"volpack": str(Path(volpack.__file__).parent)}), flush=True)
    for line in sys.stdin:
        cmd = json.loads(line)
        if cmd["op"] == "cell":
            a = cells.field(cmd["name"])
            e = cells.bound(a, cmd["rel"])
            b = cells.blob(cmd["name"], cmd["rel"], a)
            s = sz3(a, e)
            out = api.decompress_array(b)
            ok = bool(np.abs(out.astype(np.float64) - a).max() <= e)
            dz = peers.sz3_decode(s, a.dtype, a.shape)
            cell = {"calls": {"volpack": lambda b=b: api.decompress_array(b),
                              "sz3": lambda s=s, a=a: peers.sz3_decode(s, a.dtype, a.shape)}}
            best = {"volpack": 1e9, "sz3": 1e9}
            cell["best"] = best
            reply = {"hash": hashlib.sha256(out.tobytes()).hexdigest()[:16], "ok": ok,
                     "sz3_ok": bool(np.abs(dz.astype(np.float64) - a).max() <= e),
                     "voxels": int(a.size), "nbytes": int(a.nbytes), "len": len(b),
                     "sz3_len": len(s)}
        else:  # a turn
            names = ["volpack", "sz3"][:: 1 if cmd["r"] % 2 == 0 else -1]
            for m in names:
                for _ in range(cmd["inner"]):
                    t0 = time.process_time()
                    cell["calls"][m]()
                    cell["best"][m] = min(cell["best"][m], time.process_time() - t0)
            reply = cell["best"]
        print(json.dumps(reply), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trees", default="base=/tmp/ldec31/base,branch=.")
    ap.add_argument("--fields", required=True)
    ap.add_argument("--rels", default="1e-2,1e-3,1e-4,1e-5")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--inner", type=int, default=3)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    trees = dict(t.split("=") for t in args.trees.split(","))
    procs = {}
    for label, tree in trees.items():
        env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()), OMP_NUM_THREADS="1",
                   OPENBLAS_NUM_THREADS="1", MKL_NUM_THREADS="1")
        p = subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env)
        print(label, json.loads(p.stdout.readline())["volpack"], flush=True)
        procs[label] = p

    def ask(label, obj):
        p = procs[label]
        p.stdin.write(json.dumps(obj) + "\n")
        p.stdin.flush()
        return json.loads(p.stdout.readline())

    (la, lb) = list(trees)
    rows = []
    for name in args.fields.split(","):
        for rel in [float(r) for r in args.rels.split(",")]:
            info = {lab: ask(lab, {"op": "cell", "name": name, "rel": rel}) for lab in trees}
            best = {}
            for r in range(args.rounds):
                for lab in ([la, lb] if r % 2 == 0 else [lb, la]):
                    best[lab] = ask(lab, {"op": "turn", "r": r, "inner": args.inner})
            i = info[la]
            row = {"field": name, "rel": f"{rel:g}", "voxels": i["voxels"],
                   "ratio": round(i["nbytes"] / i["len"], 2),
                   "same": info[la]["hash"] == info[lb]["hash"],
                   "bound_ok": info[la]["ok"] and info[lb]["ok"]}
            for lab in trees:
                v, s = best[lab]["volpack"], best[lab]["sz3"]
                row[f"ms_{lab}"] = round(1e3 * v, 3)
                row[f"ms_sz3_{lab}"] = round(1e3 * s, 3)
                row[f"MBps_{lab}"] = round(i["nbytes"] / 1e6 / v, 1)
                row[f"x_sz3_{lab}"] = round(s / v, 3)
            row["speedup"] = round(best[la]["volpack"] / best[lb]["volpack"], 3)
            rows.append(row)
            print(",".join(str(v) for v in row.values()), flush=True)
    for p in procs.values():
        p.stdin.close()
        p.wait()
    with args.out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    if "--worker" in sys.argv:
        worker()
    else:
        main()
