"""`volpack walk` as a user runs it, in a process of its own and served by `volpack serve`.

For each round, runs ``volpack -q walk VPK OUT/ --orbit N --json`` twice, alternating:
once with ``VOLPACK_SERVE=0`` (the command in its own process) and once while a server of
this install listens (started here on a private socket, warm, before the first round).
Records when frame 0's PNG appears after the spawn (polled every 5 ms) and the whole
command's wall time; one untimed run of each comes first. Checks that both runs wrote
the same frames, byte for byte. Writes ``OUT_DIR/walk.csv`` (one row a run) and
``OUT_DIR/walk.png``, and prints the medians.

With ``--tree NAME=PATH`` (twice or more) it compares source trees instead, each in a
process of its own: ``python -m volpack`` of this interpreter with ``PYTHONPATH=PATH``
(the ``volpack`` console script runs whichever tree is installed), the trees
alternating in each round, and checks that every tree wrote the same frames.

    python scripts/bench_walk_served.py o.vpk --rounds 3 --orbit 6 --out results/render/serve19
    python scripts/bench_walk_served.py o.vpk --rounds 5 --tree main=/work/main --tree branch=.
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

EXE = str(Path(sys.executable).with_name("volpack"))


def once(vpk: str, out: Path, orbit: int, env: dict) -> tuple[float, float]:
    """(seconds to frame 0's PNG, seconds for the whole command) of one walk."""
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    first_png = out / "frame_00000.png"
    # -m puts the working directory first on sys.path: run from the output's parent, so
    # that PYTHONPATH alone decides which tree runs
    exe = [sys.executable, "-m", "volpack"] if "PYTHONPATH" in env else [EXE]
    cmd = [*exe, "-q", "walk", vpk, f"{out}/", "--orbit", str(orbit), "--json"]
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, cwd=out.parent, stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL)  # fmt: skip
    first = None
    while p.poll() is None:
        if first is None and first_png.exists():
            first = time.perf_counter() - t0
        time.sleep(0.005)
    total = time.perf_counter() - t0
    if p.returncode:
        raise SystemExit(f"{' '.join(cmd)} failed with exit {p.returncode}")
    return (total if first is None else first), total


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk", help="an octree .vpk (volpack compress --octree)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--orbit", type=int, default=6, help="frames of the walk")
    ap.add_argument("--out", type=Path, default=Path("results/render/serve"))
    ap.add_argument("--tree", action="append", default=[], metavar="NAME=PATH",
                    help="a source tree to run in its own process (give two or more)")  # fmt: skip
    args = ap.parse_args(argv)
    args.vpk = str(Path(args.vpk).resolve())
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="volpack-walk-") as d:
        tmp = Path(d)
        (tmp / "serve").mkdir(mode=0o700)
        served = dict(os.environ, VOLPACK_SERVE_DIR=str(tmp / "serve"))
        served.pop("VOLPACK_SERVE", None)
        sides = {"own process": dict(served, VOLPACK_SERVE="0"), "served": served}
        if args.tree:
            trees = dict(t.split("=", 1) for t in args.tree)
            sides = {name: dict(served, VOLPACK_SERVE="0", PYTHONPATH=str(Path(p).resolve()))
                     for name, p in trees.items()}  # fmt: skip
        else:
            subprocess.run([EXE, "serve", "--detach", "--idle", "0"], env=served, check=True)
        try:
            for side, env in sides.items():  # untimed: caches warm, kernels loaded
                once(args.vpk, tmp / side, args.orbit, env)
            for r in range(args.rounds):
                for side, env in sides.items():
                    first, total = once(args.vpk, tmp / side, args.orbit, env)
                    rows.append({"round": r, "side": side, "frame0_s": round(first, 3),
                                 "whole_s": round(total, 3)})  # fmt: skip
                    print(f"  round {r} {side:12s} frame 0 {first:6.3f} s  whole {total:6.3f} s",
                          flush=True)  # fmt: skip
        finally:
            if not args.tree:
                subprocess.run([EXE, "serve", "--stop"], env=served, check=True,
                               capture_output=True)  # fmt: skip
        first, *others = sides
        frames = sorted(os.listdir(tmp / first))
        same = all(
            frames == sorted(os.listdir(tmp / o))
            and all((tmp / first / f).read_bytes() == (tmp / o / f).read_bytes() for f in frames)
            for o in others
        )
    for row in rows:
        row["frames_identical"] = same
    with open(args.out / "walk.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    med = {s: [statistics.median(r[k] for r in rows if r["side"] == s)
               for k in ("frame0_s", "whole_s")] for s in sides}  # fmt: skip
    for s, (f0, whole) in med.items():
        print(f"{s:12s} median frame 0 {f0:.3f} s, whole walk {whole:.3f} s")
    print(f"frames byte-identical: {same} ({len(frames)} frames)")
    chart(med, args.out / "walk.png", args.orbit, list(sides))
    print(f"wrote {args.out / 'walk.csv'} and walk.png")
    return 0 if same else 1


def chart(med: dict, path: Path, orbit: int, sides: list[str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    colors = [f"C{j}" for j in range(len(sides))]
    w = 0.8 / len(sides)
    for i, key in enumerate((0, 1)):
        ax.bar([i - 0.4 + w * (j + 0.5) for j in range(len(sides))],
               [med[s][key] for s in sides], w, color=colors)  # fmt: skip
    ax.set_xticks([0, 1])
    ax.set_xticklabels(["frame 0 on disk", f"whole walk, {orbit} frames"])
    ax.set_ylabel("wall seconds from the spawn (median)")
    ax.legend(handles=[plt.Rectangle((0, 0), 1, 1, color=c) for c in colors], labels=sides,
              fontsize=8)  # fmt: skip
    ax.set_title("volpack walk: " + " / ".join(sides))
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
