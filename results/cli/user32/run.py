"""Run each volume of make.py through the command line as a user would.

    PYTHONPATH=. python results/cli/user32/run.py DIR OUT.csv [--no-peers] [NAMES...]

Per volume: `volpack compress F F.vpk` (time, ratio), `volpack info F.vpk`,
`volpack decompress F.vpk back.npy` compared bit for bit with F, then `volpack compare F
--peers --json` (best peer), and for floats `--rel-error 1e-3 --peers --json`. The first
line of any error message is kept.
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

VP = [sys.executable, "-m", "volpack", "-q"]


def run(args, timeout=1800):
    t = time.perf_counter()
    try:
        p = subprocess.run(VP + args, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, "", "timeout", time.perf_counter() - t
    return p.returncode, p.stdout, p.stderr, time.perf_counter() - t


def first_error(err):
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    return lines[-1][:200] if lines else ""


def best_peer(js):
    d = json.loads(js)
    peers = d.get("peers") or []
    ok = [p for p in peers if p.get("ratio") and not p.get("error")]
    best = max(ok, key=lambda p: p["ratio"]) if ok else None
    return d.get("ratio"), (best["name"] if best else ""), (best["ratio"] if best else None)


def main(folder: Path, out_csv: Path, names: list[str], peers: bool = True) -> None:
    names = names or [ln.split("\t")[0] for ln in (folder / "volumes.txt").read_text().splitlines()]
    work = folder / "out"
    work.mkdir(exist_ok=True)
    rows = []
    for name in names:
        src = folder / f"{name}.npy"
        a = np.load(src)
        row = {"volume": name, "dtype": str(a.dtype), "shape": "x".join(map(str, a.shape))}
        vpk = work / f"{name}.vpk"
        vpk.unlink(missing_ok=True)  # (a run again: compress refuses to overwrite)
        (work / f"{name}_back.npy").unlink(missing_ok=True)
        rc, o, e, t = run(["compress", str(src), str(vpk)])
        row["compress_s"] = round(t, 2)
        row["compress_rc"] = rc
        if rc == 0:
            row["ratio"] = round(a.nbytes / os.path.getsize(vpk), 3)
            rc, o, e2, _ = run(["info", str(vpk), "--json"])
            row["info_rc"] = rc
            if rc == 0:
                info = json.loads(o)
                row["info_shape"] = "x".join(map(str, info["header"]["shape"]))
                row["info_dtype"] = info["header"]["dtype"]
            back = work / f"{name}_back.npy"
            rc, o, e3, t = run(["decompress", str(vpk), str(back)])
            row["decompress_s"] = round(t, 2)
            if rc == 0:
                b = np.load(back)
                same = b.dtype == a.dtype and b.shape == a.shape and a.tobytes() == b.tobytes()
                row["roundtrip"] = "exact" if same else f"DIFFERS {b.dtype} {b.shape}"
            else:
                row["roundtrip"] = "decompress failed: " + first_error(e3)
        else:
            row["error"] = first_error(e)
        if not peers:
            rows.append(row)
            print(row, flush=True)
            write(rows, out_csv)
            continue
        rc, o, e, t = run(["compare", str(src), "--peers", "--json"])
        row["compare_s"] = round(t, 1)
        if rc == 0:
            r, bn, br = best_peer(o)
            row.update(cmp_ratio=r, best_peer=bn, best_peer_ratio=br)
            row["x_best"] = round(r / br, 3) if r and br else None
        else:
            row["compare_error"] = first_error(e)
        if a.dtype.kind in "fc":
            rc, o, e, t = run(["compare", str(src), "--rel-error", "1e-3", "--peers", "--json"])
            if rc == 0:
                r, bn, br = best_peer(o)
                d = json.loads(o)
                row.update(lossy_ratio=r, lossy_max_error=d.get("max_error"), lossy_best_peer=bn,
                           lossy_best_ratio=br)
                row["lossy_x_best"] = round(r / br, 3) if r and br else None
            else:
                row["lossy_error"] = first_error(e)
        print(row, flush=True)
        rows.append(row)
        write(rows, out_csv)


def write(rows, out_csv):
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with open(out_csv, "w", newline="") as f:
        w = csv.DictWriter(f, keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    args = [a for a in sys.argv[3:] if a != "--no-peers"]
    main(Path(sys.argv[1]), Path(sys.argv[2]), args, "--no-peers" not in sys.argv)
