"""Refinement (refine=1, 2, 3) and post-classification: CPU ms a frame and PSNR against the
same classification at step 0.125. Usage: python refine.py FIELD.npy opaque[,semi]"""

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


def image(tf, sh, az, step, **k):
    """The frame at azimuth ``az`` (2 threads, 512^2)."""
    cam = Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512))
    return render(prep, tf=tf, camera=cam, step=step, shading=sh, workers=2, **k)


for tfk in sys.argv[2].split(","):
    tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
    for sh in ("none", "phong"):
        refs = {
            c: image(tf, sh, 30.0, 0.125, classification=c)[..., :3]
            for c in ("preintegrated", "post")
        }
        out = []
        for kw in (dict(refine=1), dict(refine=2), dict(refine=3), dict(classification="post")):
            k = dict(classification="preintegrated")
            k.update(kw)
            img = image(tf, sh, 30.0, 0.5, **k)[..., :3]
            ts = []
            for _ in range(3):
                for az in (40.0, 50.0, 60.0):
                    c = time.process_time()
                    image(tf, sh, az, 0.5, **k)
                    ts.append(time.process_time() - c)
            ref_k = refs[k["classification"]]
            out.append(f"{kw}: cpu {np.median(ts) * 1000:.0f} ms psnr {b.psnr(img, ref_k):.1f}")
        print(name, tfk, sh, " | ".join(out), flush=True)
