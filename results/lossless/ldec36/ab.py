"""Decode speed of two volpack trees on capture.py's items, the peer beside.

Each tree runs in a worker process of its own (PYTHONPATH set to the tree); the workers
take turns, never at once. Per item each worker times, in rotating order, ``pf``: every
predictfit stream of the item through its ``predictfit.decode`` (the streams capture.py
kept), ``whole``: ``api.decompress_array`` of the item's .vpk with one worker, and the
peer's decode in the same process: JPEG-LS per slice for a lossless volume (imagecodecs,
as ``volpack compare --peers`` runs it, one thread), SZ3 for a lossy cell (pysz, its
defaults, the same absolute bound). CPU seconds of the worker's process, best of
``--rounds`` turns of ``--inner`` calls each. ``same``: both trees decoded the same bits.

    python results/lossless/ldec36/ab.py --trees base=/tmp/ldec36/base,branch=. \\
        --items ct_head,brainsmall --rounds 5 --out results/lossless/ldec36/ab_tune.csv
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
    import capture
    import numpy as np

    import volpack
    from volpack import api, peers
    from volpack.volume_codec import predictfit as pf

    print(json.dumps({"volpack": str(Path(volpack.__file__).parent)}), flush=True)
    calls = {}
    for line in sys.stdin:
        cmd = json.loads(line)
        if cmd["op"] == "item":
            item = cmd["name"]
            a, e = capture.array(item)
            b = capture.blob(item)
            st = capture.streams(item)
            h = hashlib.sha256()
            for s in st:
                h.update(np.ascontiguousarray(pf.decode(*s)).tobytes())
            whole = api.decompress_array(b, workers=1)
            if e is None:
                (peer,) = [p for p in peers._image_codecs(a.dtype, a.shape, (), (1,)) if p.name == "jpegls"]
                pb = peer.encode(a)
                pdec, pname = (lambda pb=pb, peer=peer: peer.decode(pb)), "jpegls"
                assert np.array_equal(pdec(), a)
            else:
                sb = peers.sz3_encoder()(a, e)
                pdec, pname = (lambda sb=sb, a=a: peers.sz3_decode(sb, a.dtype, a.shape)), "sz3"
            calls = {"pf": lambda st=st: [pf.decode(*s) for s in st],
                     "whole": lambda b=b: api.decompress_array(b, workers=1), "peer": pdec}
            reply = {"pf_hash": h.hexdigest()[:16],
                     "whole_hash": hashlib.sha256(np.ascontiguousarray(whole).tobytes()).hexdigest()[:16],
                     "voxels": int(a.size), "nbytes": int(a.nbytes), "streams": len(st),
                     "pf_voxels": int(sum(np.prod(s[1]) for s in st)), "peer": pname}
        else:
            names = list(calls)
            k = cmd["r"] % len(names)
            reply = {}
            for m in names[k:] + names[:k]:
                t = time.process_time()
                for _ in range(cmd["inner"]):
                    calls[m]()
                reply[m] = (time.process_time() - t) / cmd["inner"]
        print(json.dumps(reply), flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--trees", default="base=/tmp/ldec36/base,branch=.")
    ap.add_argument("--items", required=True)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--inner", type=int, default=1)
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    trees = dict(t.split("=") for t in args.trees.split(","))
    procs = {}
    for name, path in trees.items():
        env = dict(os.environ, PYTHONPATH=str(Path(path).resolve()), OMP_NUM_THREADS="1")
        p = subprocess.Popen([sys.executable, __file__, "--worker"], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env)
        print(name, p.stdout.readline().strip(), flush=True)
        procs[name] = p

    def ask(p, cmd):
        p.stdin.write(json.dumps(cmd) + "\n")
        p.stdin.flush()
        return json.loads(p.stdout.readline())

    rows = []
    for item in args.items.split(","):
        info = {n: ask(p, {"op": "item", "name": item}) for n, p in procs.items()}
        best = {n: {} for n in procs}
        for r in range(args.rounds):
            order = list(procs) if r % 2 == 0 else list(procs)[::-1]
            for n in order:
                got = ask(procs[n], {"op": "turn", "r": r, "inner": args.inner})
                for m, t in got.items():
                    best[n][m] = min(best[n].get(m, 1e9), t)
        (b, c) = list(procs)
        i0 = info[b]
        row = {"item": item, "voxels": i0["voxels"], "streams": i0["streams"], "pf_voxels": i0["pf_voxels"],
               "same": all(info[n]["pf_hash"] == i0["pf_hash"] and info[n]["whole_hash"] == i0["whole_hash"]
                           for n in procs),
               "peer": i0["peer"]}
        for n in procs:
            row[f"pf_{n}_ms"] = round(1e3 * best[n]["pf"], 2)
            row[f"whole_{n}_ms"] = round(1e3 * best[n]["whole"], 2)
            row[f"peer_{n}_ms"] = round(1e3 * best[n]["peer"], 2)
        row["pf_speedup"] = round(best[b]["pf"] / best[c]["pf"], 3)
        row["whole_speedup"] = round(best[b]["whole"] / best[c]["whole"], 3)
        for n in procs:
            row[f"pf_{n}_ns"] = round(1e9 * best[n]["pf"] / max(i0["pf_voxels"], 1), 1)
            row[f"whole_{n}_MBs"] = round(i0["nbytes"] / best[n]["whole"] / 1e6, 1)
            row[f"x_peer_{n}"] = round(best[n]["peer"] / best[n]["whole"], 3)
        row["load"] = f"{os.getloadavg()[0]:.1f}"
        print(json.dumps(row), flush=True)
        rows.append(row)
    for p in procs.values():
        p.stdin.close()
        p.wait()
    if args.out:
        with args.out.open("w", newline="") as f:
            w = csv.DictWriter(f, list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    if "--worker" in sys.argv:
        worker()
    else:
        main()
