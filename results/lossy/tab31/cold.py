"""tab31: decode CPU of the base tree and the branch, the branch's arith tables warm
(cached by an earlier decode) and cold (the cache emptied before every decode: what a
one-shot decompress of a field pays), and how many arith decodes a decode runs.

Cells: ldec31's (its cells.py, its streams) and ``ct_head`` (lossless: ``api.compress_array``
without a bound, made once by the base tree). Two worker processes (PYTHONPATH = the tree)
take turns; each turn decodes ``--inner`` times per variant; the best CPU time is kept.

    python results/lossy/tab31/cold.py --cells ct_head,hgt_500:1e-2 --out results/lossy/tab31/cold.csv
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
LDEC = HERE.parent / "ldec31"
CT_BLOB = Path("/tmp/tab31/ct_head.vpk")


def worker() -> None:
    sys.path.insert(0, str(LDEC))
    import cells
    import numpy as np

    from volpack import api
    from volpack.entropy import arith

    clear = getattr(arith, "clear_tables", lambda: None)  # the base tree has no cache
    count = [0]
    plain = arith.decode

    def counted(*a, **k):
        count[0] += 1
        return plain(*a, **k)

    arith.decode = counted  # CODERS names the module: its decode looked up per call
    print(json.dumps({"ok": 1}), flush=True)
    calls = {}
    for line in sys.stdin:
        cmd = json.loads(line)
        if cmd["op"] == "cell":
            name, rel = cmd["name"], cmd["rel"]
            if name == "ct_head":
                a = cells.field("ct_head")
                if not CT_BLOB.exists():
                    CT_BLOB.write_bytes(bytes(api.compress_array(a)))
                b = CT_BLOB.read_bytes()
            else:
                a = cells.field(name)
                b = cells.blob(name, rel, a)
            count[0] = 0
            out = api.decompress_array(b)
            n = count[0]
            calls = {"warm": lambda b=b: api.decompress_array(b),
                     "cold": lambda b=b: (clear(), api.decompress_array(b))}  # fmt: skip
            best = {k: 1e9 for k in calls}
            reply = {"hash": hashlib.sha256(out.tobytes()).hexdigest()[:16],
                     "exact": bool(np.array_equal(out, a)) if rel == 0 else None,
                     "arith_decodes": n, "voxels": int(a.size), "len": len(b),
                     "nbytes": int(a.nbytes)}  # fmt: skip
        else:
            for k in (["warm", "cold"] if cmd["r"] % 2 == 0 else ["cold", "warm"]):
                for _ in range(cmd["inner"]):
                    t0 = time.process_time()
                    calls[k]()
                    best[k] = min(best[k], time.process_time() - t0)
            reply = best
        print(json.dumps(reply), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trees", default="base=/tmp/tab31/base,branch=.")
    ap.add_argument("--cells", required=True, help="name:rel,... (ct_head: lossless)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--inner", type=int, default=3)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    trees = dict(t.split("=") for t in args.trees.split(","))
    procs = {}
    for label, tree in trees.items():
        env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()), OMP_NUM_THREADS="1")
        p = subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env)  # fmt: skip
        p.stdout.readline()
        procs[label] = p

    def ask(label, obj):
        procs[label].stdin.write(json.dumps(obj) + "\n")
        procs[label].stdin.flush()
        return json.loads(procs[label].stdout.readline())

    la, lb = list(trees)
    out = None
    for c in args.cells.split(","):
        name, _, rel = c.partition(":")
        rel = float(rel or 0)
        info = {lab: ask(lab, {"op": "cell", "name": name, "rel": rel}) for lab in trees}
        best = {}
        for r in range(args.rounds):
            for lab in [la, lb] if r % 2 == 0 else [lb, la]:
                best[lab] = ask(lab, {"op": "turn", "r": r, "inner": args.inner})
        row = {"field": name, "rel": f"{rel:g}", "voxels": info[la]["voxels"],
               "ratio": round(info[la]["nbytes"] / info[la]["len"], 2),
               "arith_decodes": info[lb]["arith_decodes"],
               "same": info[la]["hash"] == info[lb]["hash"], "exact": info[lb]["exact"],
               "ms_base": round(1e3 * best[la]["warm"], 3),
               "ms_branch_warm": round(1e3 * best[lb]["warm"], 3),
               "ms_branch_cold": round(1e3 * best[lb]["cold"], 3)}  # fmt: skip
        row["speedup_warm"] = round(row["ms_base"] / row["ms_branch_warm"], 3)
        row["speedup_cold"] = round(row["ms_base"] / row["ms_branch_cold"], 3)
        if out is None:  # rows written as they come: a cut run keeps its cells
            f = args.out.open("w", newline="")
            out = csv.DictWriter(f, fieldnames=list(row))
            out.writeheader()
        out.writerow(row)
        f.flush()
        print(json.dumps(row), flush=True)
    f.close()
    for p in procs.values():
        p.stdin.close()
        p.wait()


if __name__ == "__main__":
    worker() if "--worker" in sys.argv else main()
