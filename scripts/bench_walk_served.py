"""Time `volpack walk` as a user runs it, in its own process (``VOLPACK_SERVE=0``) and
served by a listening ``volpack serve``: when frame 0's PNG appears after the spawn, and
the whole command; alternating rounds after one untimed run of each, medians printed,
and whether the two runs' frames are byte-identical.

    volpack serve --detach && python scripts/bench_walk_served.py o.vpk 3 6   # VPK ROUNDS FRAMES
"""
import json, os, shutil, statistics, subprocess, sys, time
from pathlib import Path
vpk, rounds, orbit = sys.argv[1], int(sys.argv[2]), sys.argv[3]
exe = str(Path(sys.executable).with_name("volpack"))
base = dict(os.environ)
res = {"own": [], "served": []}
def once(kind):
    out = Path(f"/tmp/walkbench/{kind}")
    shutil.rmtree(out, ignore_errors=True); out.mkdir(parents=True)
    env = dict(base, VOLPACK_SERVE="0") if kind == "own" else base
    t0 = time.perf_counter()
    p = subprocess.Popen([exe, "-q", "walk", vpk, str(out) + "/", "--orbit", orbit, "--json"],
                         env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    first = None
    while p.poll() is None:
        if first is None and (out / "frame_00000.png").exists():
            first = time.perf_counter() - t0
        time.sleep(0.005)
    total = time.perf_counter() - t0
    if first is None and (out / "frame_00000.png").exists(): first = total
    assert p.returncode == 0, p.returncode
    return first, total
for kind in ("own", "served"):
    once(kind)  # untimed
for _ in range(rounds):
    for kind in ("own", "served"):
        res[kind].append(once(kind))
for kind, v in res.items():
    print(kind, "frame 0 at", [round(a, 3) for a, _ in v], "whole", [round(b, 3) for _, b in v],
          "median frame0 %.3f whole %.3f" % (statistics.median(a for a, _ in v), statistics.median(b for _, b in v)))
same = all((Path("/tmp/walkbench/own") / f).read_bytes() == (Path("/tmp/walkbench/served") / f).read_bytes()
           for f in os.listdir("/tmp/walkbench/own") if f.endswith(".png"))
print("frames byte-identical:", same, len(os.listdir("/tmp/walkbench/own")))
