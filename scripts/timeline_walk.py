"""A timeline of a fresh ``volpack walk`` process up to frame 0: imports, kernel loads,
stages, by thread, in seconds since the process started.

Each run spawns ``python -c DRIVER`` with ``PYTHONPATH=TREE`` (the tree under test
decides, as in ``bench_walk_served.py --tree``), ``VOLPACK_SERVE=0``, from a neutral
directory. The driver installs an import hook that instruments modules as they load
(so imports happen in their natural order): every ``volpack`` module's execution, each
numba cache load of a kernel (``_jit``'s cache class), and the walk's stages
(coarse level, renderer imports, reservation, rehearsal and its steps, the waits, the
frame's select / decode / render, the PNG write). Then it runs ``volpack -q walk VPK OUT/
--orbit N --json`` as ``python -m volpack`` would. Times are ``CLOCK_BOOTTIME`` seconds
since the process's start (``/proc``, 10 ms resolution for the start itself, so all
runs share one offset error); the hook costs a few microseconds per event.

Prints per run the kernel loads (thread, start, duration, name) and the stage events,
and a summary over runs (median of frame 0's end, the kernels loaded before frame 0,
their summed time, the main thread's time in loads, the time the main thread waited).

    python scripts/timeline_walk.py /work/lead/walk/o.vpk --tree . --runs 3 --out results/render/walk21/timeline_branch.txt
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

DRIVER = r"""
import json, os, sys, threading, time, importlib.abc, importlib.util
def _start():
    with open("/proc/self/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[19]) / os.sysconf("SC_CLK_TCK")
T0 = _start()
def now():
    return time.clock_gettime(time.CLOCK_BOOTTIME) - T0
EV = []
def ev(kind, name, t0, t1=None, cpu=None):
    EV.append((kind, name, threading.current_thread().name, round(t0, 5),
               None if t1 is None else round(t1, 5), None if cpu is None else round(cpu, 5)))
def wrap(owner, attr, kind, label=None):
    fn = getattr(owner, attr)
    def w(*a, **k):
        t0, c0 = now(), time.thread_time()
        try:
            return fn(*a, **k)
        finally:
            ev(kind, label or attr, t0, now(), time.thread_time() - c0)
            if label == "png write":  # the process's CPU (every thread) at that point
                ev("mark", "process cpu", now(), None, time.process_time())
    setattr(owner, attr, w)
def patch(name, mod):
    if name == "volpack._jit" and mod._KERNEL_CACHE is not None:
        kc = mod._KERNEL_CACHE
        load = kc.load_overload
        def load_overload(self, sig, ctx):
            t0, c0 = now(), time.thread_time()
            try:
                return load(self, sig, ctx)
            finally:
                ev("load", self._name.split(" ")[1] if " " in self._name else self._name, t0,
                   now(), time.thread_time() - c0)
        kc.load_overload = load_overload
    for owner, attr, kind, label in WRAPS.get(name, ()):
        wrap(getattr(mod, owner) if owner else mod, attr, kind, label)
# module -> (class or "" for the module, function, kind, label) wrapped when it loads
WRAPS = {
    "volpack.cli.play": [("", "_coarse", "stage", "coarse level")],
    "volpack.render.rehearse": [("Rehearsal", "_scans", "stage", "rehearse_scans"),
                                ("Rehearsal", "_writes", "stage", "rehearse_writes"),
                                ("Rehearsal", "_render", "stage", "rehearse_render"),
                                ("Rehearsal", "wait", "wait", "rehearsal.wait")],
    "volpack.render.lod": [("", "render_lod", "stage", "render_lod"),
                           ("NodeAtlas", "reserve", "stage", "atlas.reserve"),
                           ("", "tree_range", "stage", "tree_range")],
    "volpack.render.resident": [("ResidentVolume", "update", "stage", "frame decode (resident update)")],
    "volpack.render.raycast": [("", "render", "stage", "raycast.render"),
                               ("", "_frame_tables", "stage", "TF tables")],
    "volpack.render.prepared": [("PreparedVolume", "leap_map", "stage", "leap map"),
                                ("PreparedVolume", "brick_ranges", "stage", "brick ranges")],
    "volpack.render.normals": [("NormalCodes", "ensure", "stage", "normal codes")],
    "volpack.render.autotf": [("", "transfer_for", "stage", "transfer_for")],
    "volpack.render.framing": [("", "fit_camera", "stage", "fit_camera")],
    "volpack.render.movie": [("MovieWriter", "write", "stage", "png write")],
    "volpack.render.image": [("", "ready_png", "stage", "ready_png")],
    "volpack.octree.select": [("", "by_view", "stage", "select")],
    "concurrent.futures._base": [("Future", "result", "wait", "future.result")],
}
def instrument(loader, name):
    inner = loader.exec_module
    def exec_module(mod):
        t0, c0 = now(), time.thread_time()
        inner(mod)
        if name.startswith(("volpack", "numba")) and name.count(".") < 3:
            ev("import", name, t0, now(), time.thread_time() - c0)
        patch(name, mod)
    loader.exec_module = exec_module  # on this loader object only: its class stays
class Finder(importlib.abc.MetaPathFinder):
    busy = False
    def find_spec(self, name, path, target=None):
        if Finder.busy:
            return None
        Finder.busy = True
        try:
            spec = None
            for f in sys.meta_path:
                if f is self or not hasattr(f, "find_spec"):
                    continue
                spec = f.find_spec(name, path, target)
                if spec is not None:
                    break
        finally:
            Finder.busy = False
        if spec is not None and spec.loader is not None and hasattr(spec.loader, "exec_module"):
            instrument(spec.loader, name)
        return spec
sys.meta_path.insert(0, Finder())
import atexit
ev("mark", "driver ready", now())
def dump():
    with open(os.environ["TIMELINE_OUT"], "w") as f:
        json.dump(EV, f)
atexit.register(dump)
sys.argv = ["volpack"] + json.loads(os.environ["TIMELINE_ARGS"])
from volpack.launch import run
run()
"""


def one(tree: Path, vpk: str, orbit: int, extra: list[str]) -> list:
    with tempfile.TemporaryDirectory(prefix="walktl") as d:
        out = Path(d) / "out"
        out.mkdir()
        evfile = Path(d) / "ev.json"
        env = dict(os.environ, PYTHONPATH=str(tree), VOLPACK_SERVE="0", TIMELINE_OUT=str(evfile),
                   TIMELINE_ARGS=json.dumps(["-q", "walk", vpk, f"{out}/", "--orbit", str(orbit),
                                             "--json", *extra]))  # fmt: skip
        subprocess.run([sys.executable, "-c", DRIVER], env=env, cwd=d, check=True,
                       stdout=subprocess.DEVNULL)  # fmt: skip
        return json.loads(evfile.read_text())


def frame0_end(evs: list) -> float:
    return min(e[4] for e in evs if e[1] == "png write")


def summary(evs: list) -> dict:
    f0 = frame0_end(evs)
    loads = [e for e in evs if e[0] == "load" and e[3] < f0]
    main = [e for e in loads if e[2] == "MainThread"]
    waits = [e for e in evs if e[0] == "wait" and e[2] == "MainThread" and e[3] < f0]
    lod = min((e for e in evs if e[1] == "render_lod"), key=lambda e: e[3])
    cpu = min((e for e in evs if e[1] == "process cpu"), key=lambda e: e[3])[5]
    return {"cpu_at_f0": cpu,
        "frame0_end": f0, "render_lod_start": lod[3], "render_lod_s": lod[4] - lod[3],
        "loads_before_f0": len(loads), "load_s": sum(e[4] - e[3] for e in loads),
        "main_loads": len(main), "main_load_s": sum(e[4] - e[3] for e in main),
        "main_wait_s": sum(e[4] - e[3] for e in waits),
    }  # fmt: skip


def show(evs: list, fh) -> None:
    f0 = frame0_end(evs)
    for kind, name, thread, t0, t1, cpu in sorted(evs, key=lambda e: e[3]):
        if kind == "import" and (t1 - t0) < 0.004:
            continue
        if t0 > f0 + 0.05:
            continue
        dur = "" if t1 is None else f"{1000 * (t1 - t0):7.1f} ms"
        cpu = "" if cpu is None else f"{1000 * cpu:7.1f} cpu"
        print(f"  {t0:7.3f} {dur:>10s} {cpu:>11s}  {thread[:16]:16s} {kind:6s} {name}", file=fh)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("vpk")
    ap.add_argument("--tree", default=".", help="the source tree to run (PYTHONPATH)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--orbit", type=int, default=2)
    ap.add_argument("--walk", default="", help="more walk options, one string ('-j 1')")
    ap.add_argument("--out", type=Path, help="also write the listing here")
    args = ap.parse_args(argv)
    vpk, tree = str(Path(args.vpk).resolve()), Path(args.tree).resolve()
    one(tree, vpk, 1, args.walk.split())  # untimed: the tree's kernel cache warm
    runs = [one(tree, vpk, args.orbit, args.walk.split()) for _ in range(args.runs)]
    fhs = [sys.stdout] + ([open(args.out, "w")] if args.out else [])
    for fh in fhs:
        for i, evs in enumerate(runs):
            print(f"run {i}: {json.dumps(summary(evs))}", file=fh)
            show(evs, fh)
        keys = summary(runs[0]).keys()
        med = {k: round(statistics.median(summary(r)[k] for r in runs), 4) for k in keys}
        print(f"median over {len(runs)} runs: {json.dumps(med)}", file=fh)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
