"""The fast codec's encoder against main's (28ad5ad) in one process: the same bytes on
every brick :mod:`fastenc_bricks` collected, and the encode speed, interleaved, best of N.

    python scripts/fastenc_compare.py BRICKDIR [--rounds 5] [--csv OUT] [--no-zstd] [--only A,B]

Main's ``fast.py`` and ``fastpredict.py`` are read from git and loaded beside this tree's.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import volpack.volume_codec as vc
from volpack.volume_codec.fast import FastCodec

BASE = "28ad5ad"
ROOT = Path(__file__).resolve().parent.parent


def load_main(tmp: Path):
    """Main's FastCodec, its modules named ``volpack.volume_codec.main_*``."""
    tmp.mkdir(parents=True, exist_ok=True)
    mods = {}
    for name in ("fastpredict", "fast"):
        src = subprocess.run(
            ["git", "-C", str(ROOT), "show", f"{BASE}:volpack/volume_codec/{name}.py"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        src = src.replace(
            "from . import fastpredict", "from . import main_fastpredict as fastpredict"
        )
        path = tmp / f"main_{name}.py"
        path.write_text(src)
        full = f"volpack.volume_codec.main_{name}"
        spec = importlib.util.spec_from_file_location(full, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[full] = mod
        spec.loader.exec_module(mod)
        setattr(vc, f"main_{name}", mod)
        mods[name] = mod
    return mods["fast"].FastCodec


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("bricks")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--csv")
    ap.add_argument("--tmp", default="/tmp/fastenc23/main_src")
    ap.add_argument("--no-zstd", action="store_true", help="every brick without mode 3")
    ap.add_argument("--only", help="comma-separated volume stems")
    a = ap.parse_args()
    MainCodec = load_main(Path(a.tmp))
    rows = []
    total = same = 0
    for path in sorted(Path(a.bricks).glob("*.npz")):
        d = np.load(path)
        if a.only and path.stem not in a.only.split(","):
            continue
        zs = [bool(z) and not a.no_zstd for z in d["zstd"]]
        bricks = [d[f"b{i}"] for i in range(len(zs))]
        codecs = [(MainCodec(zstd=z), FastCodec(zstd=z)) for z in zs]
        for (m, o), b in zip(codecs[:1], bricks[:1]):  # compile outside the clock
            m.encode(b), o.encode(b)
        for (m, o), b in zip(codecs, bricks):
            total += 1
            same += m.encode(b) == o.encode(b)
        best = [float("inf"), float("inf")]
        for _ in range(a.rounds):  # interleaved: main, this tree, main, ...
            for k in (0, 1):
                t = time.perf_counter()
                for c, b in zip(codecs, bricks):
                    c[k].encode(b)
                best[k] = min(best[k], time.perf_counter() - t)
        mb = sum(b.nbytes for b in bricks) / 1e6
        rows.append((path.stem, len(bricks), mb / best[0], mb / best[1], best[0] / best[1]))
        print(
            f"{path.stem:22s} {len(bricks):4d} bricks  MB/s main {mb / best[0]:7.2f}  "
            f"this {mb / best[1]:7.2f}  x{best[0] / best[1]:.2f}",
            flush=True,
        )
    print(f"same bytes: {same} of {total} bricks")
    if a.csv:
        with open(a.csv, "w") as f:
            f.write("volume,bricks,main_mbs,branch_mbs,speedup\n")
            for r in rows:
                f.write(f"{r[0]},{r[1]},{r[2]:.3f},{r[3]:.3f},{r[4]:.3f}\n")
    if same != total:
        sys.exit(1)


if __name__ == "__main__":
    main()
