"""Alternate env settings of one tree: frame 0 time (first PNG appears) of volpack -q walk."""
import os, sys, time, shutil, subprocess, statistics, tempfile
from pathlib import Path
vpk, rounds, tree = sys.argv[1], int(sys.argv[2]), sys.argv[3]
variants = [dict(a.split("=", 1) for a in v.split(",") if a) if v != "-" else {} for v in sys.argv[4:]]
tmp = Path(tempfile.mkdtemp(prefix="w22alt"))
def once(extra):
    out = tmp / "out"; shutil.rmtree(out, ignore_errors=True); out.mkdir()
    env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0", **extra)
    env = {k: v for k, v in env.items() if v != ""}
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "volpack", "-q", "walk", vpk, f"{out}/", "--orbit", "1"], env=env, cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    first = None
    while p.poll() is None:
        if first is None and (out / "frame_00000.png").exists():
            first = time.perf_counter() - t0
        time.sleep(0.002)
    if first is None: first = time.perf_counter() - t0
    return first
for v in variants: once(v)
res = [[] for _ in variants]
for r in range(rounds):
    for i, v in enumerate(variants):
        res[i].append(once(v))
for i, v in enumerate(variants):
    print(v, f"median {statistics.median(res[i]):.3f} range {min(res[i]):.3f}-{max(res[i]):.3f}")
for i in range(1, len(variants)):
    d = [b - a for a, b in zip(res[0], res[i])]
    print(variants[i], f"paired vs first: median {statistics.median(d):+.3f}, faster in {sum(x < 0 for x in d)} of {len(d)}")
shutil.rmtree(tmp, ignore_errors=True)
