import sys
import time

sys.path.insert(0, "scripts")
import bench_render_peers as b

from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

name, tfk, shade = sys.argv[1], sys.argv[2], sys.argv[3]
vol, sp = b.load_warm(name, 2)
tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
prep = prepare_volume(vol, sp)
variants = {
    "default": {},
    "refine1": {"refine": 1},
    "noskip": {"skip_empty": False},
    "1thread": {"workers": 1},
}
for v, kw in variants.items():
    best = 9
    for az in (40, 50, 60, 40, 50):
        cam = Camera(azimuth=az, elevation=20, size=(512, 512))
        t = time.process_time()
        img, st = render(
            prep,
            tf=tf,
            camera=cam,
            step=0.5,
            classification="preintegrated",
            shading=shade,
            render_stats=True,
            **({"workers": 2} | kw),
        )
        best = min(best, time.process_time() - t)
    print(
        f"{name} {tfk} {shade} {v:8s} cpu {best * 1e3:6.1f} ms  samples {st.samples / 1e6:.2f} M  {st}",
        flush=True,
    )
