"""What the trials of new data kinds (results/kinds37, kinds38, kinds39) share: writing
their seeded volumes, and running each cell as a user would, one `volpack compare`
process per cell, resumable.

A trial's ``make.py`` calls :func:`write_volumes` with its makers, its held-out names and
its seed base; its ``trial.py`` calls :func:`run_trial` with a cell runner built on
:func:`run_cell`.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

import numpy as np

BOUNDS = ("1e-2", "1e-3", "1e-4")  # of the value range, for the float fields


def write_volumes(makers: dict, held_out: Iterable[str], seed: int, argv: list[str]) -> None:
    """``make.py DIR [NAME ...]``: each maker asked for (all by default) writes
    DIR/<name>.npy from ``np.random.default_rng(seed + its index)``; DIR/volumes.txt
    lists every volume present (name, int|float, tuned|held, shape, dtype)."""
    d = Path(argv[0])
    d.mkdir(parents=True, exist_ok=True)
    names = argv[1:] or list(makers)
    lines = []
    for i, name in enumerate(makers):
        rng = np.random.default_rng(seed + i)
        if name in names:
            np.save(d / f"{name}.npy", makers[name](rng))
        if not (d / f"{name}.npy").exists():  # not asked for, not made before
            continue
        a = np.load(d / f"{name}.npy", mmap_mode="r")
        kind = "float" if a.dtype.kind == "f" else "int"
        held = "held" if name in held_out else "tuned"
        lines.append(f"{name}\t{kind}\t{held}\t{'x'.join(map(str, a.shape))}\t{a.dtype}")
        print(lines[-1], flush=True)
    (d / "volumes.txt").write_text("\n".join(lines) + "\n")


def cells(d: Path, names: Iterable[str]):
    """(name, bound or None) for each cell: the float fields at every bound of BOUNDS."""
    for name in names:
        kind = np.load(d / f"{name}.npy", mmap_mode="r").dtype.kind
        for rel in BOUNDS if kind == "f" else (None,):
            yield name, rel


def run_cell(path: Path, rel: str | None, efforts: str = "7,9", extra=()) -> dict:
    """One `python -m volpack -q compare F.npy --peers --json` (``extra`` arguments, then
    ``--rel-error rel`` for a field or ``--jpegxl-efforts efforts`` for integers): its JSON,
    or the failing command's last stderr line."""
    cmd = [sys.executable, "-m", "volpack", "-q", "compare", str(path), "--peers", "--json"]
    cmd += list(extra)
    cmd += ["--rel-error", rel] if rel else ["--jpegxl-efforts", efforts]
    p = subprocess.run(cmd, capture_output=True, text=True, env=os.environ.copy())
    out = {"name": path.stem, "rel": rel, "rc": p.returncode, "json": None}
    out["stderr"] = p.stderr.strip()[-2000:]
    if p.returncode != 0:
        out["error"] = (p.stderr.strip().splitlines() or ["(no message)"])[-1][:400]
    else:
        out["json"] = json.loads(p.stdout)
    return out


def run_trial(d: Path, out: Path, names: Iterable[str], cell: Callable[[Path, str | None], dict]):
    """Run ``cell(path, bound)`` for every cell of ``names`` not already in ``out`` (JSON
    lines, appended as each ends, so an interrupted trial resumes)."""
    done = set()
    if out.exists():
        for line in open(out):
            c = json.loads(line)
            done.add((c["name"], c["rel"]))
    with open(out, "a") as f:
        for name, rel in cells(d, names):
            if (name, rel) in done:
                continue
            c = cell(d / f"{name}.npy", rel)
            f.write(json.dumps(c) + "\n")
            f.flush()
            j = c["json"]
            print(name, rel, c["rc"], c.get("error", ""), j and round(j["ratio"], 3), flush=True)
