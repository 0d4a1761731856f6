"""The trial: every volume of make.py through `volpack compare --peers` (JPEG-XL e7, e9).

    PYTHONPATH=. python results/lossless/kinds34/trial.py DIR OUTDIR [NAME ...]

One JSON per volume in OUTDIR (skipped when there), then OUTDIR/../trial.csv (or
OUTDIR.csv) with ratio, the best peer, x best peer, and decode MB/s against JPEG-LS's.
"""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path


def run(d: Path, out: Path, names: list[str]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    for n in names:
        j = out / f"{n}.json"
        if j.exists():
            continue
        cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(d / f"{n}.npy"), "--peers",
               "--jpegxl-efforts", "7,9", "--json"]  # fmt: skip
        r = subprocess.run(cmd, capture_output=True, text=True, check=True)
        j.write_text(r.stdout)
        print(n, "done", flush=True)


def table(d: Path, out: Path) -> list[dict]:
    sets = {}
    for line in (d / "volumes.txt").read_text().splitlines():
        name, kind, shape, _ = line.split("\t")
        sets[name] = (kind, shape)
    rows = []
    for name, (kind, shape) in sets.items():
        j = out / f"{name}.json"
        if not j.exists():
            continue
        r = json.loads(j.read_text())
        ps = sorted((p for p in r["peers"] if p.get("lossless")), key=lambda p: -p["ratio"])
        jls = [p for p in ps if p["name"] == "jpegls"]
        rows.append({
            "volume": name, "set": kind, "shape": shape, "ratio": round(r["ratio"], 4),
            "bytes": r["file_nbytes"], "best_peer": ps[0]["name"], "peer_ratio": round(ps[0]["ratio"], 4),
            "x_best_peer": round(r["ratio"] / ps[0]["ratio"], 4),
            "dec_mb_s": round(r["dec_mb_s_warm"], 1),
            "jpegls_dec_mb_s": round(jls[0]["dec_mb_s"], 1) if jls else "",
            "x_jpegls_dec": round(r["dec_mb_s_warm"] / jls[0]["dec_mb_s"], 3) if jls else "",
        })  # fmt: skip
    return rows


def main() -> None:
    d, out = Path(sys.argv[1]), Path(sys.argv[2])
    names = sys.argv[3:] or [
        ln.split("\t")[0] for ln in (d / "volumes.txt").read_text().splitlines()
    ]
    run(d, out, names)
    rows = table(d, out)
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
