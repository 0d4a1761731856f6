"""Samples a frame and CPU ms with and without empty-space skipping, pre-integrated and post.
Usage: python stats.py FIELD.npy opaque"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import bench_render_peers as b

from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

name = sys.argv[1]
vol, sp = b.load_warm(name, 2)
prep = prepare_volume(vol, sp)
tf = TransferFunction(points=b.tf_points(sys.argv[2], *b.tf_base(vol)))
cam = Camera(azimuth=40.0, elevation=b.ELEVATION, size=(512, 512))
for kw in (
    dict(),
    dict(skip_empty=False),
    dict(classification="post"),
    dict(classification="post", skip_empty=False),
    dict(refine=1),
):
    k = dict(classification="preintegrated", shading="none", workers=2)
    k.update(kw)
    img, st = render(prep, tf=tf, camera=cam, render_stats=True, **k)
    ts = []
    for _ in range(5):
        c = time.process_time()
        render(prep, tf=tf, camera=cam, **k)
        ts.append(time.process_time() - c)
    print(kw, f"cpu {np.median(ts) * 1000:.0f} ms", st)
