"""What the segment refinement costs and buys on small volumes' opaque frames (rend36).

    PYTHONPATH=. python results/render/rend36/refine_policy.py VOLUME ...

The peers benchmark's opaque TF, 512x512, step 0.5, 2 threads; per variant the CPU ms a
frame (best of 6 views at azimuth 40/50/60, variants interleaved) and the PSNR of the
azimuth-30 image against volpack's default at step 0.125 (the benchmark's reference).
Nothing here changes the library: the variants are ``render(refine=)`` and the module's
REFINE_OPACITY / REFINE_BEND, read at each render.
"""

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import bench_render_peers as b  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

VARIANTS = {  # name: (refine, REFINE_OPACITY, REFINE_BEND)
    "default (3, 0.1, 1)": (3, 0.1, 1.0),
    "refine=2": (2, 0.1, 1.0),
    "refine=1 (none)": (1, 0.1, 1.0),
    "opacity 0.2": (3, 0.2, 1.0),
    "bend 4": (3, 0.1, 4.0),
}


def frame(prep, tf, az, shade, var, step=0.5):
    refine, op, bend = var
    raycast.REFINE_OPACITY, raycast.REFINE_BEND = op, bend
    try:
        cam = Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512))
        c = time.process_time()
        img = raycast.render(prep, tf=tf, camera=cam, step=step, shading=shade, refine=refine,
                             workers=2)
        return img, time.process_time() - c
    finally:
        raycast.REFINE_OPACITY, raycast.REFINE_BEND = 0.1, 1.0


for name in sys.argv[1:]:
    vol, sp = b.load_warm(name, 2)
    prep = prepare_volume(vol, sp)
    label = Path(name).name.split(".")[0]
    tf = TransferFunction(points=b.tf_points("opaque", *b.tf_base(vol)))
    for shade in ("none", "phong"):
        ref, _ = frame(prep, tf, 30.0, shade, VARIANTS["default (3, 0.1, 1)"], step=0.125)
        ref = ref[..., :3].astype(np.float64)
        best = {k: 9.0 for k in VARIANTS}
        psnr = {}
        for rnd in range(2):
            for az in (40, 50, 60):
                for k, var in (VARIANTS.items() if rnd == 0 else reversed(VARIANTS.items())):
                    best[k] = min(best[k], frame(prep, tf, az, shade, var)[1])
        for k, var in VARIANTS.items():
            psnr[k] = b.psnr(frame(prep, tf, 30.0, shade, var)[0][..., :3], ref)
        d = best["default (3, 0.1, 1)"]
        for k in VARIANTS:
            print(f"{label:16s} opaque {shade:5s} {k:20s} cpu {best[k] * 1e3:6.1f} ms"
                  f" ({best[k] / d:.2f}x)  PSNR {psnr[k]:5.1f} dB", flush=True)
