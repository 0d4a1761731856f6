"""A/B timing of two volpack trees: did the renovation (issue 19) slow anything down?

Each tree is a checkout (``--old``, ``--new``; git worktrees, e.g. ``/work/ab/old`` at
0d526d3, before the renovation, and ``/work/ab/new`` at the branch tip). The same real
volumes are written once to ``.npy`` files; then each round runs one worker process per
tree, old and new in alternation (ABAB...), the worker importing volpack from its tree
(``PYTHONPATH``) with a kernel cache of its own, warmed by an untimed run of each tree
before the first round. A worker times, in CPU seconds (``time.process_time``, which
counts every thread of the process, so neighbours on a shared machine do not inflate
it), after an untimed first call of each task:

* ``lossless``: ``compress_array(a, codec="wavelet")`` then ``decompress_array`` (checked
  bit-exact). The codec is named: the default ``auto`` became the per-brick ``lossless``
  codec in 61c677e (a new method, not part of the renovation), so ``auto`` would compare
  two methods, not two layouts of one;
* ``lossy``: ``compress_array(a, max_error=E)`` then decode (every voxel checked within E);
* ``render``: one 256 x 256 frame of ``render.raycast.render`` (pre-integrated, Phong,
  the automatic transfer function; the image is checked equal between trees).

Each task runs ``--repeat`` times in a worker and the worker reports its median; the
summary gives, per task, the median over rounds of each tree, their spread (min..max)
and new/old of the medians and of the minima (the minimum is the run least disturbed by
neighbours on a shared machine). The compressed sizes must agree between the trees
(same method, same bytes). Both trees must offer the API used here (it is the same before and after).

    python scripts/ab_renovation.py --old /work/ab/old --new /work/ab/new --rounds 5

Writes ``results/renovation/ab.csv`` (one row a round, tree, dataset and task),
``results/renovation/ab_summary.csv`` and ``ab.png`` (medians with their min..max);
prints the summary table.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
# dataset -> lossy max_error (value units: CT in HU, the MRI in 8-bit grey levels)
DATASETS = {"ct_head": 8.0, "mri_ch2": 2.0}
TASKS = ("lossless", "lossy", "render")


# --------------------------------------------------------------------------- worker


def _median_cpu(fn, repeat: int) -> tuple[float, object]:
    out = fn()  # untimed: loads the kernels from the cache (or compiles them)
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return statistics.median(times), out


def worker(data: list[str], repeat: int) -> dict:
    import volpack
    from volpack.render.camera import Camera
    from volpack.render.raycast import render
    from volpack.render.transfer import auto_tf

    res = {"volpack": volpack.__file__}
    for spec in data:
        name, path, max_error = spec.split(":")
        a = np.load(path)
        e = float(max_error)

        tf = auto_tf(float(a.min()), float(a.max()), a.dtype)
        cam = Camera(size=(256, 256))

        def lossless(a=a):
            blob = volpack.compress_array(a, codec="wavelet", workers=1)
            return volpack.decompress_array(blob), len(blob)

        def lossy(a=a, e=e):
            blob = volpack.compress_array(a, max_error=e, workers=1)
            return volpack.decompress_array(blob), len(blob)

        def frame(a=a, tf=tf, cam=cam):
            return render(a, tf=tf, camera=cam, shading="phong", workers=1)

        t, (back, res[f"{name}/lossless_bytes"]) = _median_cpu(lossless, repeat)
        if not np.array_equal(back, a):
            raise SystemExit(f"{name}: lossless round trip differs")
        res[f"{name}/lossless"] = t
        t, (back, res[f"{name}/lossy_bytes"]) = _median_cpu(lossy, repeat)
        err = float(np.max(np.abs(back.astype(np.float64) - a.astype(np.float64))))
        if err > e:
            raise SystemExit(f"{name}: lossy error {err} over the bound {e}")
        res[f"{name}/lossy"] = t
        t, img = _median_cpu(frame, repeat)
        res[f"{name}/render"] = t
        res[f"{name}/render_sum"] = float(np.asarray(img, np.float64).sum())
    return res


# --------------------------------------------------------------------------- driver


def run_tree(tree: Path, cache: Path, data: list[str], repeat: int) -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree)
    env["VOLPACK_CACHE_DIR"] = str(cache)
    env.pop("NUMBA_CACHE_DIR", None)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", "--repeat", str(repeat)]
    cmd += ["--data", *data]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tempfile.gettempdir())
    if p.returncode:
        raise SystemExit(f"worker for {tree} failed:\n{p.stderr}")
    res = json.loads(p.stdout.strip().splitlines()[-1])
    if not res["volpack"].startswith(str(tree)):
        raise SystemExit(f"worker imported {res['volpack']}, not the tree {tree}")
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", type=Path, default=Path("/work/ab/old"))
    ap.add_argument("--new", type=Path, default=Path("/work/ab/new"))
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each task in a worker")
    ap.add_argument("--datasets", nargs="+", default=list(DATASETS))
    ap.add_argument("--cache", type=Path, default=None, help="parent of the kernel caches")
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "renovation")
    ap.add_argument("--replot", action="store_true", help="redraw ab.png from the CSV files")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--data", nargs="+", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(args.data, args.repeat)))
        return
    if args.replot:
        with open(args.out / "ab_summary.csv") as f:
            summary = [{k: v if k in ("dataset", "task") else float(v) for k, v in r.items()}
                       for r in csv.DictReader(f)]
        with open(args.out / "ab.csv") as f:
            rows = list(csv.DictReader(f))
        commits = {r["tree"]: r["commit"] for r in rows}
        plot(summary, commits, len({r["round"] for r in rows}), args.out / "ab.png")
        return

    sys.path.insert(0, str(ROOT / "scripts"))
    import datasets

    trees = {"old": args.old.resolve(), "new": args.new.resolve()}
    commits = {
        k: subprocess.run(["git", "-C", str(t), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip()
        for k, t in trees.items()
    }  # fmt: skip
    cache = args.cache or Path(tempfile.gettempdir()) / "volpack-ab-cache"
    tmp = Path(tempfile.mkdtemp(prefix="volpack-ab-"))
    data = []
    for name in args.datasets:
        vol, _spacing, _ = datasets.load(name)
        path = tmp / f"{name}.npy"
        np.save(path, np.ascontiguousarray(vol))
        data.append(f"{name}:{path}:{DATASETS[name]}")
        print(f"{name}: {vol.shape} {vol.dtype}", flush=True)

    for k, t in trees.items():  # warm each tree's kernel cache, untimed
        print(f"warming {k} ({commits[k]}) ...", flush=True)
        run_tree(t, cache / k, data, 1)

    args.out.mkdir(parents=True, exist_ok=True)
    rows, sums = [], {}
    for rnd in range(args.rounds):
        for k in ("old", "new") if rnd % 2 == 0 else ("new", "old"):
            res = run_tree(trees[k], cache / k, data, args.repeat)
            for name in args.datasets:
                sums.setdefault((k, name), res[f"{name}/render_sum"])
                for task in TASKS:
                    nbytes = res.get(f"{name}/{task}_bytes", "")
                    rows.append({"round": rnd, "tree": k, "commit": commits[k], "dataset": name,
                                 "task": task, "cpu_s": round(res[f"{name}/{task}"], 5),
                                 "nbytes": nbytes})
            print(f"round {rnd} {k}: " + "  ".join(
                f"{n}/{t} {res[f'{n}/{t}']:.3f}" for n in args.datasets for t in TASKS), flush=True)
    with open(args.out / "ab.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    summary = []
    print(f"\nCPU seconds, median over {args.rounds} rounds (min..max); "
          f"old {commits['old']}, new {commits['new']}")
    for name in args.datasets:
        for task in TASKS:
            cell = {}
            for k in trees:
                v = [r["cpu_s"] for r in rows if r["tree"] == k and r["dataset"] == name
                     and r["task"] == task]
                cell[k] = (statistics.median(v), min(v), max(v))
            ratio = cell["new"][0] / cell["old"][0]
            ratio_min = cell["new"][1] / cell["old"][1]
            summary.append({"dataset": name, "task": task,
                            "old_median": round(cell["old"][0], 4),
                            "old_min": round(cell["old"][1], 4), "old_max": round(cell["old"][2], 4),
                            "new_median": round(cell["new"][0], 4),
                            "new_min": round(cell["new"][1], 4), "new_max": round(cell["new"][2], 4),
                            "new_over_old": round(ratio, 3),
                            "new_over_old_min": round(ratio_min, 3)})
            o, n = cell["old"], cell["new"]
            print(f"  {name:8s} {task:9s} old {o[0]:.3f} ({o[1]:.3f}..{o[2]:.3f})  "
                  f"new {n[0]:.3f} ({n[1]:.3f}..{n[2]:.3f})  new/old {ratio:.3f} (minima {ratio_min:.3f})")
        same = np.isclose(sums[("old", name)], sums[("new", name)], rtol=1e-6)
        sizes = {(r["tree"], r["task"]): r["nbytes"] for r in rows
                 if r["dataset"] == name and r["nbytes"] != ""}
        equal = all(sizes[("old", t)] == sizes[("new", t)] for t in ("lossless", "lossy"))
        print(f"  {name}: render images {'agree' if same else 'DIFFER'}, compressed sizes "
              f"{'agree' if equal else 'DIFFER'} between trees "
              f"({', '.join(f'{t} {sizes[(k, t)]}' for k in trees for t in ('lossless', 'lossy'))})")
    with open(args.out / "ab_summary.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(summary[0]))
        w.writeheader()
        w.writerows(summary)
    plot(summary, commits, args.rounds, args.out / "ab.png")


def plot(summary: list[dict], commits: dict, rounds: int, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 3.6))
    x = np.arange(len(summary))
    for j, k in enumerate(("old", "new")):
        med = np.array([r[f"{k}_median"] for r in summary])
        lo = med - np.array([r[f"{k}_min"] for r in summary])
        hi = np.array([r[f"{k}_max"] for r in summary]) - med
        ax.bar(x + (j - 0.5) * 0.38, med, 0.38, yerr=[lo, hi], capsize=3,
               label=f"{k} ({commits[k]})")
    ax.set_xticks(x, [f"{r['dataset']}\n{r['task']}" for r in summary], fontsize=8)
    ax.set_ylabel("CPU seconds")
    ax.set_title(f"Renovation A/B: median of {rounds} alternating rounds (bars: min..max)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
