"""Session 25's renderer against main's: ch2's opaque unshaded frame, CPU ms. Usage: PYTHONPATH=TREE python ab25.py TREE"""

import sys
import time

import numpy as np

sys.path.insert(0, sys.argv[1] + "/scripts")
import bench_render_peers as b

import volpack
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

vol, sp = b.load_warm("mri_ch2", 2)
prep = prepare_volume(vol, sp)
tf = TransferFunction(points=b.tf_points("opaque", *b.tf_base(vol)))
ts = []
for az in (40.0, 50.0, 60.0, 70.0, 80.0) * 3:
    cam = Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512))
    c = time.process_time()
    render(prep, tf=tf, camera=cam, classification="preintegrated", shading="none", workers=2)
    ts.append(time.process_time() - c)
print(volpack.__file__, f"median cpu {np.median(ts) * 1000:.1f} ms, min {min(ts) * 1000:.1f}")
