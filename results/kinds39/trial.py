"""The trial, as a user runs it: one `volpack compare` process per cell (kinds38's
trial.py with JPEG-XL e10 added and this trial's makers).

    PYTHONPATH=. python results/kinds39/trial.py DIR OUT.jsonl [--held] [--no-e10] [NAME ...]

Integer volumes: `python -m volpack -q compare F.npy --peers --jpegxl-efforts 7,9,10 --json`
(`--no-e10`: 7,9). Float fields: `--rel-error E --peers --json` at E = 1e-2, 1e-3, 1e-4.
Without --held the held-out volumes are skipped; with it only they run. Each cell's JSON
(or the failing command's last stderr line) is appended to OUT.jsonl; cells already there
are not run again. compare decodes and checks every voxel against the bound.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402

BOUNDS = ("1e-2", "1e-3", "1e-4")


def run_cell(path: Path, rel: str | None, efforts: str) -> dict:
    cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(path), "--peers", "--json"]
    cmd += ["--rel-error", rel] if rel else ["--jpegxl-efforts", efforts]
    p = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    out = {"name": path.stem, "rel": rel, "rc": p.returncode, "json": None}
    out["stderr"] = p.stderr.strip()[-2000:]
    if p.returncode != 0:
        out["error"] = (p.stderr.strip().splitlines() or ["(no message)"])[-1][:400]
    else:
        out["json"] = json.loads(p.stdout)
    return out


def main() -> None:
    flags = {"--held", "--no-e10"}
    args = [a for a in sys.argv[1:] if a not in flags]
    held = "--held" in sys.argv
    efforts = "7,9" if "--no-e10" in sys.argv else "7,9,10"
    d, out = Path(args[0]), Path(args[1])
    names = args[2:] or [n for n in MAKERS if (n in HELD_OUT) == held]
    done = set()
    if out.exists():
        for line in open(out):
            c = json.loads(line)
            done.add((c["name"], c["rel"]))
    with open(out, "a") as f:
        for name in names:
            kind = np.load(d / f"{name}.npy", mmap_mode="r").dtype.kind
            for rel in BOUNDS if kind == "f" else (None,):
                if (name, rel) in done:
                    continue
                c = run_cell(d / f"{name}.npy", rel, efforts)
                f.write(json.dumps(c) + "\n")
                f.flush()
                j = c["json"]
                print(
                    name, rel, c["rc"], c.get("error", ""), j and round(j["ratio"], 3), flush=True
                )


if __name__ == "__main__":
    main()
