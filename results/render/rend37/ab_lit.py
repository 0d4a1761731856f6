"""A/B in one process: Phong frames lit through quantised normals refining through the
lean call (_refined_lit, session 37) against the full _refined (LEAN_REFINE off), on the
peers benchmark's opaque and semi TFs, first view and 4 more, 512^2, step 0.5, 2 threads.
CPU a frame, best of ROUNDS interleaved rounds; the largest difference of the images.

    PYTHONPATH=. python results/render/rend37/ab_lit.py [volume ...] > results/render/rend37/ab_lit.txt
"""

import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 7


def frames(prep, tf):
    out = None
    for az in (30.0, 40.0, 50.0, 60.0, 70.0):
        cam = Camera(azimuth=az, elevation=peers.ELEVATION, size=(512, 512))
        img = raycast.render(prep, tf=tf, camera=cam, shading="phong", workers=2)
        out = img if out is None else out
    return out


def main(names):
    for name in names:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        for tfk in ("opaque", "semi"):
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            res = {True: [], False: []}
            imgs = {}
            for _ in range(ROUNDS):
                for lean in (False, True):
                    raycast.LEAN_REFINE = lean
                    c = time.process_time()
                    imgs[lean] = frames(prep, tf)
                    res[lean].append((time.process_time() - c) / 5)
            raycast.LEAN_REFINE = True
            print(f"{Path(name).name.split('.')[0]:18s} {tfk:6s} phong: full {1e3 * min(res[False]):6.1f} ms, "
                  f"lean {1e3 * min(res[True]):6.1f} ms, ratio {min(res[True]) / min(res[False]):.3f}; "
                  f"largest difference {np.abs(imgs[True] - imgs[False]).max():.2g}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["nuclei_stardist", "heart_mayavi_float", "ct_skull_float"])
