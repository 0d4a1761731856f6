"""Encoder CPU time and peak memory of `volpack compress`, source tree against source tree.

Each tree codes each volume in a process of its own (`python -m volpack compress` with
`PYTHONPATH=<tree>`, from a neutral directory so that only `PYTHONPATH` decides), the
trees alternating within each round; the child's CPU seconds and peak resident memory
come from `os.wait4`, and every tree's file must be the same bytes (or the run says
which differ). A first round per tree warms its kernel cache and is not recorded.

    python scripts/bench_encode_trees.py ct_head:float32 ct_head --tree before=/tmp/old \\
        --tree after=. --rounds 3 --out results/lossless/encode21

A volume is a dataset name of `scripts/datasets.py`, optionally `:dtype` to cast it
(integers stored as floats, as many converted scans are), or a `.npy` path. Writes
`<out>.csv` (one row per tree, volume and round) and `<out>.png` (CPU s and peak MB per
volume, median of the rounds).
"""

from __future__ import annotations

import argparse
import csv
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def volume_file(spec: str, tmp: Path) -> Path:
    """The .npy file of ``spec`` (``name[:dtype]`` or a path), written into ``tmp``."""
    if spec.endswith(".npy"):
        return Path(spec).resolve()
    name, _, dtype = spec.partition(":")
    a = datasets.load(name)[0]
    if dtype:
        a = a.astype(dtype)
    path = tmp / f"{name}{'-' + dtype if dtype else ''}.npy"
    np.save(path, a)
    return path


def run(tree: Path, src: Path, dst: Path, extra: list[str]) -> tuple[float, float, float]:
    """(CPU s, wall s, peak MB) of one `compress` child of ``tree``."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    cmd = [sys.executable, "-m", "volpack", "-q", "compress", str(src), str(dst), "--force"]
    t = time.perf_counter()
    proc = subprocess.Popen(cmd + extra, env=env, cwd=tempfile.gettempdir())
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(cmd)} failed (PYTHONPATH={tree})")
    return usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss / 1024


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--tree", action="append", required=True, help="NAME=PATH (twice or more)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--args", default="--workers 1", help="more compress options")
    ap.add_argument("--out", default="results/lossless/encode_trees")
    args = ap.parse_args()
    trees = [(n, Path(p).resolve()) for n, p in (t.split("=", 1) for t in args.tree)]
    extra = args.args.split()
    rows = []
    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        for spec in args.volumes:
            src = volume_file(spec, tmp)
            mb = src.stat().st_size / 1e6
            for rnd in range(args.rounds + 1):
                files = {}
                for name, tree in trees:
                    dst = tmp / f"{name}.vpk"
                    cpu, wall, peak = run(tree, src, dst, extra)
                    files[name] = dst.read_bytes()
                    if rnd:
                        rows.append(dict(volume=spec, tree=name, round=rnd, cpu_s=round(cpu, 3),
                                         wall_s=round(wall, 3), peak_mb=round(peak, 1),
                                         mb=round(mb, 3), bytes=len(files[name])))  # fmt: skip
                        print(f"{spec:24s} {name:10s} round {rnd}: {cpu:7.2f} CPU s, "
                              f"{wall:7.2f} s, {peak:7.0f} MB, {len(files[name])} B", flush=True)  # fmt: skip
                if len(set(files.values())) > 1:
                    print(
                        f"{spec}: the trees' files differ: {[(n, len(b)) for n, b in files.items()]}"
                    )
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.with_suffix(".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    vols = list(dict.fromkeys(r["volume"] for r in rows))
    width = 0.8 / len(trees)
    for i, (name, _) in enumerate(trees):
        for ax, key in zip(axes, ("cpu_s", "peak_mb")):
            med = [
                statistics.median(r[key] for r in rows if r["volume"] == v and r["tree"] == name)
                for v in vols
            ]
            ax.bar(np.arange(len(vols)) + i * width, med, width, label=name)
    for ax, title in zip(axes, ("encoder CPU s (median)", "peak resident MB (median)")):
        ax.set_xticks(
            np.arange(len(vols)) + width * (len(trees) - 1) / 2, vols, rotation=20, fontsize=8
        )
        ax.set_title(title)
        ax.legend()
    fig.tight_layout()
    fig.savefig(out.with_suffix(".png"), dpi=110)
    print(f"wrote {out.with_suffix('.csv')} and {out.with_suffix('.png')}")


if __name__ == "__main__":
    main()
