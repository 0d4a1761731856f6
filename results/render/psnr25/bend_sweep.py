"""Refinement gated by the bend of the scalar along the ray: PSNR against the
benchmark's reference (step 0.125, the defaults of the code run), samples and best CPU
of 3, one thread, the benchmark's opaque TF and scene.

    python results/render/psnr25/bend_sweep.py <volumes,...> <refine:bend,...>

bend_sweep.csv: a prototype that skipped refinement below the bend (not kept: the skull
lost 5 dB); bend_count_sweep.csv: two sub-segments below the bend, ``refine`` above it
(the rule kept, ``sub_count``; its reference then was main's refine 2).
"""
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import datasets
from bench_render_peers import ELEVATION, psnr, tf_base, tf_points
from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.transfer import TransferFunction
vols = sys.argv[1].split(",")
settings = [s.split(":") for s in sys.argv[2].split(",")]  # m:bend
print("volume,shading,refine,bend_tol,psnr_db,samples,cpu_s")
for name in vols:
    vol, sp, _ = datasets.load(name)
    prep = prepare_volume(vol, tuple(float(s) for s in sp))
    tf = TransferFunction(points=tf_points("opaque", *tf_base(vol)))
    cam = Camera(azimuth=30.0, elevation=ELEVATION, size=(512, 512))
    for sh in ("none", "phong"):
        raycast.REFINE_BEND = 0.0
        ref = raycast.render(prep, tf=tf, camera=cam, step=0.125, shading=sh, workers=1)[..., :3]
        for m, b in settings:
            raycast.REFINE_BEND = float(b)
            best = 1e9
            for _ in range(3):
                c = time.process_time()
                im, st = raycast.render(prep, tf=tf, camera=cam, shading=sh, refine=int(m), workers=1, render_stats=True)
                best = min(best, time.process_time() - c)
            print(f"{name},{sh},{m},{b},{psnr(im[..., :3], ref):.2f},{st.samples},{best:.4f}", flush=True)
