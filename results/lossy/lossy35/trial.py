"""Run each field as a user would: `python -m volpack -q compare F.npy --rel-error E
--peers --json` at E = 1e-2..1e-5, one process per cell; keep ratio, x best of SZ3/SPERR,
PSNR, max error (checked against the bound here too), decode MB/s of volpack and peers.

Run: PYTHONPATH=. python results/lossy/lossy35/trial.py DIR OUT.csv [NAMES] [--held]
(DIR from make.py; without --held the held-out fields are skipped; the raw JSON of each
cell goes to OUT.jsonl, a failing command's stderr into the row; cells in OUT.jsonl
already are not run again.)
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402

BOUNDS = ("1e-2", "1e-3", "1e-4", "1e-5")


def run_cell(path: Path, rel: str) -> tuple[dict, dict | None]:
    cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(path), "--rel-error", rel,
           "--peers", "--json"]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    row: dict = {"field": path.stem, "rel": rel, "rc": p.returncode}
    if p.returncode != 0:
        row["error"] = (p.stderr.strip().splitlines() or ["(no message)"])[-1][:300]
        return row, None
    j = json.loads(p.stdout)
    return row_of(row, j), j


def r(v, n):
    return None if v is None else round(v, n)


def row_of(row: dict, j: dict) -> dict:
    c = j["compress"]
    bound = c.get("error_bound")
    row.update(
        shape="x".join(map(str, j["shape"])), dtype=j["dtype"], bound=bound,
        bytes=j["file_nbytes"], ratio=round(j["ratio"], 4), psnr=r(j["psnr"], 3),
        max_error=j["max_error"], held=bound is None or j["max_error"] <= bound,
        dec_mb_s=round(j.get("dec_mb_s_warm") or j["dec_mb_s"], 2),
        enc_s=round(j["enc_seconds"], 3),
    )  # fmt: skip
    best = None
    for q in j.get("peers", []):
        n = q["name"]
        row[f"{n}_bytes"] = q["file_nbytes"]
        row[f"{n}_ok"] = q["bound_held"]
        row[f"{n}_psnr"] = r(q.get("psnr"), 3)
        row[f"{n}_dec_mb_s"] = round(q["dec_mb_s"], 2)
        if n in ("sz3", "sperr") and q["bound_held"] and (best is None or q["file_nbytes"] < best[1]):
            best = (n, q["file_nbytes"])
    if j.get("peers_left_out"):
        row["peers_left_out"] = ";".join(map(str, j["peers_left_out"]))
    if best:
        row["best_peer"] = best[0]
        row["x_best"] = round(best[1] / j["file_nbytes"], 4)
    return row


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--held"]
    held = "--held" in sys.argv
    d, out = Path(args[0]), Path(args[1])
    only = set(args[2].split(",")) if len(args) > 2 else None
    rows, done = [], {}
    if out.with_suffix(".jsonl").exists():  # resume: cells already run are not run again
        for line in open(out.with_suffix(".jsonl")):
            c = json.loads(line)
            if c["json"] is not None:
                done[c["field"], c["rel"]] = c["json"]
    with open(out.with_suffix(".jsonl"), "a") as raw:
        for name in MAKERS:
            if (name in HELD_OUT) != held or (only and name not in only):
                continue
            for rel in BOUNDS:
                if (name, rel) in done:
                    row, j = row_of({"field": name, "rel": rel, "rc": 0}, done[name, rel]), None
                else:
                    row, j = run_cell(d / f"{name}.npy", rel)
                    raw.write(json.dumps({"field": name, "rel": rel, "json": j}) + "\n")
                    raw.flush()
                row["set"] = "held-out" if name in HELD_OUT else "tuned"
                print(row, flush=True)
                rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
