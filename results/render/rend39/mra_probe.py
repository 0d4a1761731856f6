"""Diagnosis of the held-out miss (after the held-out run, no change made from it): mra_u16's
semi-transparent unshaded frame, 1.17x VTK matched's CPU where its Phong frame is 0.94x.
One thread, CPU ms best of 5 (interleaved), segments, at the benchmark's first view.

    PYTHONPATH=. python results/render/rend39/mra_probe.py /tmp/rend39/held/mra_u16.npy
"""

import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load, psnr  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

CASES = {  # name: (shading, NEAR_RUN, NEAREST, refine)
    "none (default)": ("none", True, True, 3),
    "none, NEAR_RUN off": ("none", False, True, 3),
    "none, NEAREST off": ("none", True, False, 3),
    "none, refine=1": ("none", True, True, 1),
    "phong (default)": ("phong", True, True, 3),
}


def main(name):
    vol, sp = load(name)
    prep = prepare_volume(vol, sp)
    tf = TransferFunction(points=peers.tf_points("semi", *peers.tf_base(vol)))
    cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
    ref = rc.render(prep, tf=tf, camera=cam, step=0.125, workers=2)

    def go(k, stats=False):
        sh, nr, ne, rf = CASES[k]
        rc.NEAR_RUN, rc.NEAREST = nr, ne
        try:
            return rc.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, refine=rf,
                             workers=1, render_stats=stats)  # fmt: skip
        finally:
            rc.NEAR_RUN, rc.NEAREST = True, True

    res = {}
    for k in CASES:
        img, st = go(k, True)
        res[k] = [psnr(img, ref) if CASES[k][0] == "none" else float("nan"), st.samples, []]
    for _ in range(5):
        for k in CASES:
            c = time.process_time()
            go(k)
            res[k][2].append(time.process_time() - c)
    for k, (p, n, ts) in res.items():
        print(f"{k:20s} cpu {min(ts) * 1e3:6.1f} ms  segments {n / 1e6:5.2f} M  PSNR {p:5.2f} dB")


if __name__ == "__main__":
    main(sys.argv[1])
