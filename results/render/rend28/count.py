"""One frame's counter of kind VP_PROF (counters.diff applied to a copy of volpack/, which
also held the clear-run variant and its flag AB_CLEAR) as render_stats.samples, with the
clear run on and off. Usage: VP_PROF=K VOLPACK_JIT_CACHE=0 PYTHONPATH=COPY python count.py
FIELD.npy opaque none (see counters.txt)."""
import os
import sys

import numpy as np

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[3] / "scripts"))
import bench_render_peers as b

from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.transfer import TransferFunction

name, tfk, sh = sys.argv[1:4]
vol, sp = np.load(name), (1.0, 1.0, 1.0)
prep = prepare_volume(vol, sp)
tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
for clear in (1.0, 0.0):
    raycast.AB_CLEAR = bool(clear)
    img, st = raycast.render(prep, tf=tf, camera=Camera(azimuth=40.0, elevation=b.ELEVATION, size=(512, 512)), classification="preintegrated", shading=sh, workers=2, render_stats=True)
    print(name, tfk, sh, "prof", os.environ.get("VP_PROF"), "clearrun", clear, "count", f"{st.samples:,}", flush=True)
