"""CPU (user + sys, all threads, os.wait4) and wall of whole ``volpack -q walk VPK OUT/
--orbit 1`` processes, trees alternating (``python -m volpack`` with PYTHONPATH=TREE from
a neutral directory), one untimed run each first; medians and paired differences.

    python results/render/walk22/cpu_orbit1.py /work/lead/walk/o.vpk 6 main=/work/main branch=.
"""

import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

vpk, rounds, trees = sys.argv[1], int(sys.argv[2]), dict(a.split("=", 1) for a in sys.argv[3:])
tmp = Path(tempfile.mkdtemp(prefix="walkcpu"))


def once(tree):
    out = tmp / "out"
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir()
    env = dict(os.environ, PYTHONPATH=str(Path(tree).resolve()), VOLPACK_SERVE="0")
    t0 = time.perf_counter()
    p = subprocess.Popen([sys.executable, "-m", "volpack", "-q", "walk", vpk, f"{out}/", "--orbit",
                          "1", "--json"], env=env, cwd=tmp, stdout=subprocess.DEVNULL)  # fmt: skip
    _, status, ru = os.wait4(p.pid, 0)
    assert status == 0
    return ru.ru_utime + ru.ru_stime, time.perf_counter() - t0


for t in trees.values():
    once(t)
res = {n: [] for n in trees}
for r in range(rounds):
    for n, t in trees.items():
        res[n].append(once(t))
names = list(trees)
for n in names:
    cpu, wall = zip(*res[n])
    print(f"{n}: CPU {statistics.median(cpu):.3f} s (range {min(cpu):.3f}-{max(cpu):.3f}), "
          f"wall {statistics.median(wall):.3f} s")
a, b = names[0], names[1]
d = [y[0] - x[0] for x, y in zip(res[a], res[b])]
print(f"paired CPU {b} - {a}: median {statistics.median(d):+.3f} s, {b} less in "
      f"{sum(v < 0 for v in d)} of {len(d)}")
shutil.rmtree(tmp, ignore_errors=True)
