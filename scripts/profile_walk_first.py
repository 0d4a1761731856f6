"""Where the first frame of ``volpack walk`` goes, stage by stage, in CPU and wall seconds.

Runs ``volpack walk TREE.vpk OUT/ --orbit N --json`` in this process (the CLI's own
code, 512x512, auto TF, Phong) with timers wrapped around the functions each stage
calls, 1 + ``--repeat`` times in a row: the first walk pays what a fresh process pays
(imports, loading the cached numba kernels, first touches), the later ones only what
a walk pays again (kernels loaded; each stage's least CPU time over them is shown, the
machine being shared). Compile time is not in either: run the command once before
(``--warm`` does) so that the kernels come from the cache. Each stage's time is
inclusive of the stages it calls (e.g. ``decode: resident update`` holds the chunk
prefetch and the node writes); ``frame 0`` counts from the start of the walk command's
first ``render_lod`` call to the end of its PNG write. CPU seconds are the process's
(all threads, ``time.process_time``); minor page faults are the process's too (the
first touches of fresh memory, each zeroing a 4 kB page). Prints a table and, with ``--csv``, writes one
row per (walk, stage).

    python scripts/profile_walk_first.py /tmp/o.vpk --warm --csv results/render/walk13/stages.csv
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import io
import json
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

STAGES: dict[str, list[float]] = {}
FRAME = {"n": -1}  # render_lod calls so far in the walk


def faults() -> int:
    """Minor page faults of the process so far (first touches of fresh memory)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def timed(owner, name: str, stage: str, clock=time.process_time):
    """Wrap ``owner.name`` so its calls during frame 0 (or before it) add to ``stage``
    (CPU by ``clock``: the process's, or ``time.thread_time`` for what runs on the
    worker threads, summed over them)."""
    fn = getattr(owner, name)

    @functools.wraps(fn)
    def wrapper(*a, **k):
        if FRAME["n"] > 0:
            return fn(*a, **k)
        w0, c0, f0 = time.perf_counter(), clock(), faults()
        try:
            return fn(*a, **k)
        finally:
            acc = STAGES.setdefault(stage, [0.0, 0.0, 0, 0])
            acc[0] += time.perf_counter() - w0
            acc[1] += clock() - c0
            acc[2] += 1
            acc[3] += faults() - f0

    setattr(owner, name, wrapper)


def install() -> None:
    from volpack.octree import reader, select
    from volpack.render import lod, movie, normals, prepared, raycast, resident
    from volpack.render import autotf, framing

    timed(reader.Octree, "__init__", "open container")
    timed(lod, "tree_range", "value range")
    timed(lod, "coarse_level", "coarse level (auto TF)")
    timed(autotf, "transfer_for", "auto TF")
    timed(framing, "fit_camera", "fit camera")
    timed(select, "by_view", "select")
    timed(resident.ResidentVolume, "update", "decode: resident update")
    timed(reader.Octree, "prefetch", "decode: chunk prefetch (threads)")
    timed(reader.Octree, "assemble", "decode: write nodes (assemble)")
    if hasattr(reader.Octree, "resampled"):  # on the worker threads: thread CPU, summed
        timed(reader.Octree, "resampled", "decode: write boxes (threads)", time.thread_time)
    if hasattr(reader.Octree, "_lift_up"):
        timed(reader.Octree, "_lift_up", "decode: chunks (threads)", time.thread_time)
    timed(prepared.PreparedVolume, "rewritten", "decode: rewritten (ranges, grads)")
    timed(resident, "cell_boxes", "decode: cell boxes")
    timed(raycast, "render", "render")
    timed(prepared.PreparedVolume, "brick_ranges", "render: brick ranges")
    timed(prepared.PreparedVolume, "memo", "render: empty bricks")
    timed(prepared.PreparedVolume, "leap_map", "render: leap map")
    timed(prepared.PreparedVolume, "normal_codes", "render: normal codes (alloc)")
    timed(normals.NormalCodes, "ensure", "render: normal codes")
    timed(raycast, "_frame_tables", "render: TF tables")
    timed(raycast.Camera, "rays", "render: camera rays")
    timed(raycast, "run_row_sets", "render: march")
    timed(movie.MovieWriter, "write", "image write (PNG)")
    orig = lod.render_lod

    @functools.wraps(orig)
    def counted(*a, **k):
        FRAME["n"] += 1
        if FRAME["n"] == 0:
            FRAME["t0"] = (time.perf_counter(), time.process_time())
            FRAME["f0"] = faults()
        return orig(*a, **k)

    lod.render_lod = counted
    wr = movie.MovieWriter.write

    def write(self, rgba):
        wr(self, rgba)
        if FRAME["n"] == 0:
            w0, c0 = FRAME["t0"]
            STAGES["frame 0"] = [time.perf_counter() - w0, time.process_time() - c0, 1,
                                 faults() - FRAME["f0"]]

    movie.MovieWriter.write = write


def walk(vpk: str, orbit: int, extra: list[str]) -> dict:
    from volpack.cli import main as cli

    out = Path(tempfile.mkdtemp(prefix="walkprof"))
    STAGES.clear()
    FRAME["n"] = -1
    buf = io.StringIO()
    w0, c0, f0 = time.perf_counter(), time.process_time(), faults()
    with contextlib.redirect_stdout(buf):
        try:
            cli.main(["walk", vpk, str(out) + "/", "--orbit", str(orbit), "--json", *extra],
                     standalone_mode=False)  # fmt: skip
        finally:
            shutil.rmtree(out, ignore_errors=True)
    STAGES["walk command"] = [time.perf_counter() - w0, time.process_time() - c0, 1, faults() - f0]
    rep = json.loads(buf.getvalue())
    f0 = rep["per_frame"][0]
    return {"stages": {k: list(v) for k, v in STAGES.items()}, "frame0": f0}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--orbit", type=int, default=2)
    ap.add_argument("--warm", action="store_true", help="run the walk once in a child first")
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--label", default="")
    ap.add_argument("--repeat", type=int, default=3, help="walks after the first (best of)")
    ap.add_argument("--walk", default="", help="more walk options, one string ('-j 1')")
    args = ap.parse_args(argv)
    args.extra = args.walk.split()
    if args.warm:
        import subprocess

        d = tempfile.mkdtemp(prefix="walkwarm")
        subprocess.run([sys.executable, "-m", "volpack", "walk", args.vpk, d + "/", "--orbit",
                        "1", "--json", *args.extra], check=True, capture_output=True)  # fmt: skip
        shutil.rmtree(d, ignore_errors=True)
    t0, c0 = time.perf_counter(), time.process_time()
    import volpack.cli  # noqa: F401  (what a fresh process imports before the command)
    imp = [time.perf_counter() - t0, time.process_time() - c0, 1, 0]
    install()
    rows = []
    runs = [("fresh process", walk(args.vpk, args.orbit, args.extra))]
    runs[0][1]["stages"]["import volpack.cli"] = imp
    later = [walk(args.vpk, args.orbit, args.extra) for _ in range(args.repeat)]
    if later:  # each stage's least CPU (and its wall) over the later walks
        best = {name: min((r["stages"][name] for r in later if name in r["stages"]),
                          key=lambda v: v[1]) for name in later[0]["stages"]}  # fmt: skip
        f0 = min((r["frame0"] for r in later), key=lambda f: sum(f["cpu_s"]))
        runs.append((f"later walk (best of {len(later)})", {"stages": best, "frame0": f0}))
    for run, r in runs:
        f0 = r["frame0"]
        print(f"\n{run}: frame 0 select/decode/render "
              f"{1000 * f0['select_s']:.0f}/{1000 * f0['decode_s']:.0f}/{1000 * f0['render_s']:.0f}"
              f" ms wall, {1000 * sum(f0['cpu_s']):.0f} ms CPU; {f0['nodes']} nodes,"
              f" {f0['decoded']} decoded")  # fmt: skip
        print(f"{'stage':42s} {'calls':>5s} {'wall ms':>8s} {'CPU ms':>8s} {'faults':>8s}")
        for name, (w, c, n, f) in r["stages"].items():
            print(f"{name:42s} {n:5d} {1000 * w:8.1f} {1000 * c:8.1f} {f:8d}")
            rows.append({"label": args.label, "run": run, "stage": name, "calls": n,
                         "wall_ms": round(1000 * w, 2), "cpu_ms": round(1000 * c, 2),
                         "minor_faults": f})  # fmt: skip
    if args.csv:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from bench_workers import append_csv

        append_csv(rows, args.csv)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
