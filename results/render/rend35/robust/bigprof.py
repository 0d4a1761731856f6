# ruff: noqa: E402  (imports timed after the memory watcher starts)
import sys
import threading
import time

peak = [0]


def rss():
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) // 1024


def watch():
    while True:
        peak[0] = max(peak[0], rss())
        time.sleep(0.02)


threading.Thread(target=watch, daemon=True).start()
t0 = time.time()


def mark(s):
    time.sleep(0.05)
    print(f"{time.time() - t0:6.1f} s  rss {rss()} MB  peak {peak[0]} MB  {s}", flush=True)


from volpack import io as vio
from volpack.render.autotf import transfer_for
from volpack.render.camera import Camera
from volpack.render.framing import fit_camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render

mark("imports")
vol = vio.read_volume(sys.argv[1])
data = vol.data
mark(f"read {type(data)} {data.flags['C_CONTIGUOUS']}")
lo, hi = float(data.min()), float(data.max())
mark("minmax")
tf = transfer_for(None, data, lo=lo, hi=hi, dtype=data.dtype, mask=None, size=max(data.shape))
mark("autotf")
view = fit_camera(
    Camera(size=(512, 512)),
    data,
    tf,
    lo,
    hi,
    spacing=vol.spacing,
    shape=None,
    factor=1,
    mask=None,
    isos=None,
    azimuths=None,
)
mark("fit")
pv = prepare_volume(vol)
mark("prepare")
shading = sys.argv[2] if len(sys.argv) > 2 else "phong"
img = render(pv, tf=tf, camera=view, shading=shading, value_range=(lo, hi), workers=2)
mark("render 1")
img = render(pv, tf=tf, camera=view, shading=shading, value_range=(lo, hi), workers=2)
mark("render 2")
