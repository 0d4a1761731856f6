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
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from volpack import api, peers
from volpack.volume_codec import lossless

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))

BASE_SNIPPET = """
import sys, numpy as np
from volpack import api
print(len(api.compress_array(np.load(sys.argv[1]), workers=1)))
"""


def load(folder: Path, name: str) -> tuple[np.ndarray, Path]:
    path = folder / f"{name}.npy"
    if not path.exists():
        from datasets import load as load_corpus

        np.save(path, load_corpus(name)[0])
    return np.load(path), path


def encode(a: np.ndarray, old: bool) -> bytes:
    saved = lossless.REPEAT
    lossless.REPEAT = not old
    try:
        return api.compress_array(a, workers=1)
    finally:
        lossless.REPEAT = saved


def cpu(fn, *args) -> float:
    """CPU seconds of one call (every thread of this process)."""
    t = time.process_time()
    fn(*args)
    return time.process_time() - t


def best_peer(a: np.ndarray) -> tuple[str, float]:
    found, _ = peers.lossless(a.dtype, a.shape)
    best = ("-", 0.0)
    for p in found:
        blob = p.encode(a)
        if not np.array_equal(p.decode(blob), a):
            continue
        ratio = a.nbytes / peers.nbytes(blob)
        if ratio > best[1]:
            best = (p.name, ratio)
    return best


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
        hdr = api.info(new)
        row = {
            "volume": name, "dtype": a.dtype.name, "shape": "x".join(map(str, a.shape)),
            "bytes_base": base, "base_equal": base == "" or base == len(old), "same_file": old == new, "bytes_before": len(old), "bytes_after": len(new),
            "ratio_before": round(a.nbytes / len(old), 4), "ratio_after": round(a.nbytes / len(new), 4),
            "gain_pct": round(100 * (len(old) / len(new) - 1), 2),
            "best_peer": peer, "peer_ratio": round(peer_ratio, 4),
            "x_peer_before": round(a.nbytes / len(old) / peer_ratio, 4) if peer_ratio else "",
            "x_peer_after": round(a.nbytes / len(new) / peer_ratio, 4) if peer_ratio else "",
            "enc_cpu_before": round(enc["old"], 3), "enc_cpu_after": round(enc["new"], 3),
            "dec_cpu_before": round(dec["old"], 3), "dec_cpu_after": round(dec["new"], 3),
            "tools_after": ";".join(f"{k}:{v}" for k, v in sorted(hdr["summary"]["tools"].items())),
        }  # fmt: skip
        print(row, flush=True)
        rows.append(row)
        with open(args.out, "w", newline="") as f:  # (after every volume)
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)


if __name__ == "__main__":
    main()
