"""Alternate two environments of the same tree: frame 0's PNG time after spawn."""
import os, subprocess, sys, time, shutil, statistics
from pathlib import Path
tree, var, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
vpk = "/work/lead/walk/o.vpk"
def once(env, out):
    shutil.rmtree(out, ignore_errors=True); out.mkdir(parents=True)
    p0 = out / "frame_00000.png"
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "volpack", "-q", "walk", vpk, f"{out}/", "--orbit", "2", "--json"],
                         env=env, cwd=out.parent, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    first = None
    while p.poll() is None:
        if first is None and p0.exists(): first = time.perf_counter() - t0
        time.sleep(0.005)
    return first
base = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0")
sides = {"on": base, "off": dict(base, **{var: "1"})}
tmp = Path("/tmp/w21/abenv"); res = {k: [] for k in sides}
for s, e in sides.items(): once(e, tmp / s)
for r in range(rounds):
    for s, e in (sides.items() if r % 2 == 0 else reversed(list(sides.items()))):
        res[s].append(once(e, tmp / s))
d = [a - b for a, b in zip(res["on"], res["off"])]
print({k: round(statistics.median(v), 3) for k, v in res.items()}, "paired on-off median %.3f, on wins %d/%d" % (statistics.median(d), sum(x < 0 for x in d), len(d)))
