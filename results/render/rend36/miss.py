"""Per-frame fixed cost of a small volume: a clear TF (every brick empty) at zoom 1, and at
zooms where most or all rays miss the box (rend36). PYTHONPATH=. python results/render/rend36/miss.py nuclei_stardist"""
import sys
import time

sys.path.insert(0, "scripts")
import bench_render_peers as b

from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

vol, sp = b.load_warm(sys.argv[1], 2)
prep = prepare_volume(vol, sp)
clear = TransferFunction(points=[(float(vol.min()), 0, 0, 0, 0), (float(vol.max()), 1, 1, 1, 0)])
for w in (2, 1):
  for zoom in (1.0, 0.25, 0.02):
    best = 9
    for az in (40, 50, 60, 40, 50, 60, 40):
        cam = Camera(azimuth=az, elevation=20, size=(512, 512), zoom=zoom)
        t = time.process_time()
        img = render(prep, tf=clear, camera=cam, workers=w)
        best = min(best, time.process_time() - t)
    print(f"workers {w} zoom {zoom}: clear frame cpu {best*1e3:.1f} ms", flush=True)
