"""Where one ``volpack render`` process spends its time, stage by stage, tree against tree.

Each round starts a fresh process per source tree (alternating, so machine load hits all
alike) that runs ``volpack render`` in itself, as the console entry does, with its stages
timed (wall and process CPU, all threads):

* ``cli`` (click and ``volpack.cli``), ``numpy``, ``numba`` (``volpack._jit``: numba
  and its set-up), ``render modules`` (what the render command imports: io, camera,
  ray caster, Pillow), in that order, each on top of the ones before; the last three
  inside ``imports_without_gc`` where the tree has it, as the command imports them;
* ``read``: the volume file (``volpack.cli.render._load``);
* ``kernel loads``: the first call of each compiled kernel the render runs (numba's
  ``_compile_for_args``: its cache found, loaded and linked; ``loads`` counts them;
  those on the ray caster's worker threads count the other thread's CPU meanwhile);
* ``render``: the ray caster's own work (tables, brick ranges, normals, rays), its
  kernel loads taken out; ``png``: ``save_png``; ``other``: the rest of the command;
* ``process``: the whole process as the parent sees it (interpreter start and exit
  included), and ``start+exit``: that minus everything above.

Kernels must be in the cache (one untimed run per tree comes first). The benchmark's
inputs (:mod:`bench_render_process`: raw NRRD, its TF JSON) are written to a temporary
folder. Bytecode as in :mod:`bench_render_process` (``--no-bytecode`` likewise). Writes
``stages.csv`` (median of ``--rounds`` per tree and stage) under ``--out``.

    python scripts/profile_render_process.py main=/work/main branch=. \\
        [--cases zmap_neurovault:semi:phong ...] [--rounds 7] [--out results/render/s15]
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
STAGES = ("cli", "numpy", "numba", "render modules", "read", "kernel loads", "render", "png",
          "other", "start+exit", "process")  # fmt: skip


def child(argv) -> int:
    """Run ``volpack render ARGV`` here with its stages timed; print them as JSON."""
    clock = {"wall": time.perf_counter, "cpu": time.process_time}
    acc = {s: {"wall": 0.0, "cpu": 0.0} for s in STAGES}
    acc["loads"] = 0

    def add(stage, t0):
        for k, f in clock.items():
            acc[stage][k] += f() - t0[k]

    def now():
        return {k: f() for k, f in clock.items()}

    begin = now()
    t0 = now()
    import volpack.cli
    import volpack.cli.options as options

    add("cli", t0)
    # as the console entry runs a command (volpack.cli.run), and as the render command
    # imports its libraries: inside imports_without_gc, where a tree has it
    options.WHOLE_PROCESS = True
    pause = getattr(options, "imports_without_gc", contextlib.nullcontext)
    imports = (("numpy", ["numpy"]), ("numba", ["volpack._jit"]),
               ("render modules", ["volpack.cli.render", "volpack.io", "volpack.io.nrrd",
                                   "volpack.render.camera", "volpack.render.raycast",
                                   "volpack.render.image", "PIL.Image"]))  # fmt: skip
    with pause():
        for stage, modules in imports:
            t0 = now()
            for m in modules:
                __import__(m)
            add(stage, t0)

    from numba.core.dispatcher import Dispatcher

    import volpack.cli.render as cli_render
    import volpack.render.image as image
    import volpack.render.raycast as raycast

    def timed(obj, name, stage, count=False):
        fn = getattr(obj, name)

        def wrapper(*a, **k):
            t0 = now()
            before = dict(acc["kernel loads"])
            try:
                return fn(*a, **k)
            finally:
                add(stage, t0)
                if count:
                    acc["loads"] += 1
                elif stage != "other":  # its kernel loads are counted there, not here
                    for key in clock:
                        acc[stage][key] -= acc["kernel loads"][key] - before[key]

        setattr(obj, name, wrapper)

    timed(Dispatcher, "_compile_for_args", "kernel loads", count=True)
    timed(cli_render, "_load", "read")
    timed(raycast, "render", "render")
    timed(image, "save_png", "png")
    t0 = now()
    try:
        volpack.cli.main(["render", *argv], standalone_mode=False)
    except SystemExit as e:
        if e.code:
            raise
    add("other", t0)
    acc["in-process"] = {k: f() - begin[k] for k, f in clock.items()}
    for k in clock:  # the nested stages out of the command's time: each second counted once
        acc["other"][k] -= sum(acc[s][k] for s in ("read", "kernel loads", "render", "png"))
    print(json.dumps(acc))
    sys.stdout.flush()
    os._exit(0)  # as volpack.cli.run does: no teardown of numba


def run_child(tree: str, args_: list[str], env: dict) -> dict:
    env = dict(env, PYTHONPATH=tree)
    t0 = time.perf_counter()
    r0 = os.times()
    out = subprocess.run([sys.executable, __file__, "--child", *args_], env=env,
                         capture_output=True, text=True, check=True)  # fmt: skip
    wall = time.perf_counter() - t0
    r1 = os.times()
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    acc = json.loads(out.stdout.strip().splitlines()[-1])
    acc["process"] = {"wall": wall, "cpu": cpu}
    inside = acc.pop("in-process")
    acc["start+exit"] = {k: acc["process"][k] - inside[k] for k in ("wall", "cpu")}
    return acc


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return child(argv[1:])
    sys.path.insert(0, str(ROOT / "scripts"))
    import datasets
    from bench_render_peers import tf_base, tf_points

    from volpack.api import write_volume
    from volpack.render.transfer import TransferFunction
    from volpack.volume import Volume

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trees", nargs="+", help="NAME=PATH: a source tree to put on PYTHONPATH")
    ap.add_argument("--cases", nargs="+", default=["zmap_neurovault:semi:phong",
                                                   "ct_head:opaque:none"])  # fmt: skip
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "render" / "s15")
    ap.add_argument("--bytecode", action=argparse.BooleanOptionalAction, default=True,
                    help="a private bytecode cache, as bench_render_process.py gives")
    args = ap.parse_args(argv)
    trees = [t.split("=", 1) for t in args.trees]
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory(prefix="volpack-stages-") as d:
        tmp = Path(d)
        env = dict(os.environ)
        if args.bytecode:  # as installed (bench_render_process.py's docstring)
            env["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
            env.pop("PYTHONDONTWRITEBYTECODE", None)
        for case in args.cases:
            name, tfk, shading = case.split(":")
            vol, spacing, _ = datasets.load(name)
            path = tmp / f"{name}.nrrd"
            if not path.exists():
                write_volume(Volume(vol, spacing=tuple(float(s) for s in spacing)), str(path))
            tf_path = tmp / f"{name}-{tfk}.json"
            tf = TransferFunction(points=tuple(tf_points(tfk, *tf_base(vol))), name=tfk)
            tf_path.write_text(tf.to_json())
            cmd = [str(path), str(tmp / "out.png"), "--force", "--tf", str(tf_path), "--no-fit",
                   "--step", "0.5", "--size", "512x512", "-j", str(args.workers),
                   "--shading", shading]  # fmt: skip
            runs = {t: [] for t, _ in trees}
            for t, path_ in trees:  # untimed: kernels cached, bytecode written
                run_child(path_, cmd, env)
            for r in range(args.rounds):
                for t, path_ in trees if r % 2 == 0 else trees[::-1]:
                    runs[t].append(run_child(path_, cmd, env))
            for t, _ in trees:
                row = {"case": case, "tree": t, "rounds": args.rounds,
                       "loads": statistics.median(a["loads"] for a in runs[t])}  # fmt: skip
                for s in STAGES:
                    for k in ("wall", "cpu"):
                        row[f"{s} {k}_s"] = round(statistics.median(a[s][k] for a in runs[t]), 4)
                rows.append(row)
                print(f"{case:28s} {t:8s} loads {row['loads']:3.0f}  " + "  ".join(
                    f"{s} {row[f'{s} wall_s']:.3f}/{row[f'{s} cpu_s']:.3f}" for s in STAGES),
                    flush=True)  # fmt: skip
    with open(args.out / "stages.csv", "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)
    print(f"wrote {args.out / 'stages.csv'} (median wall/cpu s per stage)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
