"""A/B in one process: fit_camera's visibility pass at base (7424c95, framing.py from git)
against this branch, on a volume file; time and the peak of traced allocations.

    PYTHONPATH=. python results/render/rend35/ab_framing.py /tmp/rend35/rob/big1024.npy
"""

import importlib.util
import subprocess
import sys
import time
import tracemalloc

from volpack import io as vio
from volpack.render import framing as new
from volpack.render.autotf import transfer_for
from volpack.render.camera import Camera

src = subprocess.run(["git", "show", "7424c95:volpack/render/framing.py"], capture_output=True,
                     text=True, check=True).stdout.replace("from .", "from volpack.render.")
spec = importlib.util.spec_from_loader("framing_old", loader=None)
old = importlib.util.module_from_spec(spec)
exec(src, old.__dict__)

vol = vio.read_volume(sys.argv[1])
data = vol.data
lo, hi = float(data.min()), float(data.max())
tf = transfer_for(None, data, lo=lo, hi=hi, dtype=data.dtype, size=max(data.shape))
print(f"{sys.argv[1]} {data.shape} {data.dtype} ({data.nbytes / 2**20:.0f} MB)")
cams = {}
for rnd in range(2):
    for name, mod in (("base", old), ("new", new)):
        tracemalloc.start()
        t0 = time.perf_counter()
        cams[name] = mod.fit_camera(Camera(size=(512, 512)), data, tf, lo, hi, spacing=vol.spacing)
        dt = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(f"round {rnd} {name:4s} fit_camera {dt:7.2f} s  peak allocations {peak / 2**20:8.1f} MB")
print("same camera:", cams["base"] == cams["new"])
