"""The trial, as a user runs it: one `volpack compare` process per cell.

    PYTHONPATH=. python results/kinds38/trial.py DIR OUT.jsonl [--held] [--fill] [NAME ...]

Integer volumes: `python -m volpack -q compare F.npy --peers --jpegxl-efforts 7,9 --json`.
Float fields: `python -m volpack -q compare F.npy --rel-error E --peers --json` at
E = 1e-2, 1e-3, 1e-4. Without --held the held-out volumes are skipped; with it only they
run. Each cell's JSON (or the failing command's last stderr line) is appended to
OUT.jsonl; cells already there are not run again. With --fill, the fields with a fill
value (FILL) get `--fill-value` as a user told by volpack's warning would give it. Every bound is checked here on the
JSON's max error too (compare itself decodes and checks every voxel).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from make import HELD_OUT, MAKERS  # noqa: E402

BOUNDS = ("1e-2", "1e-3", "1e-4")
FILL = {"letkf_t": "-9.9999e30", "letkf_qv": "-9.9999e30"}


def cells(d: Path, names):
    for name in names:
        a = __import__("numpy").load(d / f"{name}.npy", mmap_mode="r")
        if a.dtype.kind == "f":
            for e in BOUNDS:
                yield name, e
        else:
            yield name, None


def run_cell(path: Path, rel: str | None, fill: bool = False) -> dict:
    cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(path), "--peers", "--json"]
    if fill and path.stem in FILL:
        cmd += ["--fill-value", FILL[path.stem]]
    cmd += ["--rel-error", rel] if rel else ["--jpegxl-efforts", "7,9"]
    p = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    out = {"name": path.stem, "rel": rel, "rc": p.returncode, "json": None}
    out["stderr"] = p.stderr.strip()[-2000:]
    if p.returncode != 0:
        out["error"] = (p.stderr.strip().splitlines() or ["(no message)"])[-1][:400]
    else:
        out["json"] = json.loads(p.stdout)
    return out


def main() -> None:
    args = [a for a in sys.argv[1:] if a not in ("--held", "--fill")]
    fill = "--fill" in sys.argv
    held = "--held" in sys.argv
    d, out = Path(args[0]), Path(args[1])
    names = args[2:] or [n for n in MAKERS if (n in HELD_OUT) == held]
    done = set()
    if out.exists():
        for line in open(out):
            c = json.loads(line)
            done.add((c["name"], c["rel"]))
    with open(out, "a") as f:
        for name, rel in cells(d, names):
            if (name, rel) in done:
                continue
            c = run_cell(d / f"{name}.npy", rel, fill)
            f.write(json.dumps(c) + "\n")
            f.flush()
            j = c["json"]
            print(name, rel, c["rc"], c.get("error", ""), j and round(j["ratio"], 3), flush=True)


if __name__ == "__main__":
    main()
