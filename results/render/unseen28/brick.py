"""Empty-space bricks of 4^3 against 8^3 (monkeypatched FINE_BRICK): CPU ms a frame.
Usage: python brick.py FIELD.npy"""

import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import bench_render_peers as b

from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

name = sys.argv[1]
vol, sp = b.load_warm(name, 2)
for tfk in ("semi", "opaque"):
    tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
    for sh in ("none", "phong"):
        res = []
        for fb in (4, 8, 4, 8):
            raycast.FINE_BRICK = fb
            prep = prepare_volume(vol, sp)
            k = dict(classification="preintegrated", shading=sh, workers=2)
            render(
                prep,
                tf=tf,
                camera=Camera(azimuth=35.0, elevation=b.ELEVATION, size=(512, 512)),
                **k,
            )
            ts = []
            for az in (40.0, 50.0, 60.0, 70.0, 80.0):
                c = time.process_time()
                render(
                    prep,
                    tf=tf,
                    camera=Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512)),
                    **k,
                )
                ts.append(time.process_time() - c)
            res.append(f"b{fb} {np.median(ts) * 1000:.0f}")
        print(name.split("/")[-1], tfk, sh, res, flush=True)
