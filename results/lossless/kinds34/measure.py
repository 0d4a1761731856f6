"""Volumes before and after session 34's repeated slices (mode 6), in one process.

    PYTHONPATH=. python results/lossless/kinds34/measure.py DIR OUT.csv [--repeat N]
        [--base BASE] [--no-peers] [--peers-from trial.csv] NAME ...

DIR holds NAME.npy (``make.py``; a corpus name of scripts/datasets.py is loaded from
there instead). "before" is 10dcf4d's default made by today's code with mode 6 switched
off (lossless.REPEAT = False); BASE (10dcf4d's ``volpack/`` in a folder: ``git archive
10dcf4d volpack | tar -x -C BASE``) makes the base's own default stream in a subprocess,
whose length must equal before's. Encode and decode CPU seconds (time.process_time, workers=1)
are the best of N runs, old and new interleaved. Peers: volpack.peers.lossless as
``volpack compare --peers`` runs them (JPEG-XL efforts 7 and 9), the best by ratio.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from volpack import api
from volpack.volume_codec import lossless

# thin33's measure.py: its corpus loader, its base-stream snippet and its best peer
_spec = importlib.util.spec_from_file_location(
    "thin33_measure", Path(__file__).resolve().parents[1] / "thin33" / "measure.py"
)
thin33 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(thin33)
load, best_peer, BASE_SNIPPET = thin33.load, thin33.best_peer, thin33.BASE_SNIPPET


def encode(a: np.ndarray, old: bool) -> bytes:
    saved = lossless.REPEAT
    lossless.REPEAT = not old
    try:
        return api.compress_array(a, workers=1)
    finally:
        lossless.REPEAT = saved


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("dir", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("names", nargs="+")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--base", type=Path)
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--peers-from", type=Path, help="trial.csv: its best peers, not run again")
    args = ap.parse_args()
    known = {}
    if args.peers_from:
        with open(args.peers_from) as f:
            known = {
                r["volume"]: (r["best_peer"], float(r["peer_ratio"])) for r in csv.DictReader(f)
            }
    rows = []
    warm = (
        np.load(args.dir / f"{args.names[0]}.npy")[:40, :40, :40]
        if (args.dir / f"{args.names[0]}.npy").exists()
        else None
    )
    if warm is not None:  # (kernels compiled or loaded before any timing)
        api.decompress_array(encode(np.ascontiguousarray(warm), False))
    for name in dict.fromkeys(args.names):
        a, path = load(args.dir, name)
        enc = {"old": float("inf"), "new": float("inf")}
        dec, blobs = dict(enc), {}
        for _ in range(args.repeat):  # interleaved: old, new, old, new (the first runs' files kept)
            for key, flag in (("old", True), ("new", False)):
                t = time.process_time()
                blob = encode(a, flag)
                enc[key] = min(enc[key], time.process_time() - t)
                blob = blobs.setdefault(key, blob)
                t = time.process_time()
                back = api.decompress_array(blob)
                dec[key] = min(dec[key], time.process_time() - t)
                assert back.dtype == a.dtype and np.array_equal(back, a), name
        old, new = blobs["old"], blobs["new"]
        base = ""
        if args.base:
            run = subprocess.run(
                [sys.executable, "-c", BASE_SNIPPET, str(path)], capture_output=True, text=True,
                env={**os.environ, "PYTHONPATH": str(args.base)}, check=True,
                cwd="/",  # (not this tree: python -c puts the working folder first)
            )  # fmt: skip
            base = int(run.stdout.split()[-1])
        peer, peer_ratio = known.get(name) or (("", 0.0) if args.no_peers else best_peer(a))
        row = {"volume": name, "dtype": a.dtype.name, "shape": "x".join(map(str, a.shape))}
        row.update(bytes_base=base, base_equal=base in ("", len(old)), same_file=old == new)
        row.update(best_peer=peer, peer_ratio=round(peer_ratio, 4))
        for when, key, blob in (("before", "old", old), ("after", "new", new)):
            ratio = a.nbytes / len(blob)
            row[f"bytes_{when}"], row[f"ratio_{when}"] = len(blob), round(ratio, 4)
            row[f"x_peer_{when}"] = round(ratio / peer_ratio, 4) if peer_ratio else ""
            row[f"enc_cpu_{when}"], row[f"dec_cpu_{when}"] = round(enc[key], 3), round(dec[key], 3)
        row["gain_pct"] = round(100 * (len(old) / len(new) - 1), 2)
        tools = api.info(new)["summary"]["tools"]
        row["tools_after"] = ";".join(f"{k}:{v}" for k, v in sorted(tools.items()))
        print(row, flush=True)
        rows.append(row)
        with open(args.out, "w", newline="") as f:  # (after every volume)
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
