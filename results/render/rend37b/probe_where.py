"""Where the opaque frames' time goes (session 37, rend37b; issue 22): CPU ms a frame
(best of ``ROUNDS``, settings interleaved), segments a frame, ns a segment and PSNR
against the default's step-0.125 image, for refinement as it is (3 sub-segments where
the scalar bends, else 2), at most 2 and none (``refine=1``), at the peers benchmark's
first view (azimuth 30, 512^2, step 0.5, 2 threads).

    PYTHONPATH=. python results/render/rend37b/probe_where.py VOLUME ... [--tfs opaque]
"""

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load, psnr  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 5
REFINES = (3, 2, 1)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--tfs", nargs="+", default=["opaque"])
    a = ap.parse_args()
    for name in a.volumes:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        for tfk in a.tfs:
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            for sh in ("none", "phong"):
                ref = raycast.render(prep, tf=tf, camera=cam, step=0.125, shading=sh, workers=2)
                res = {}
                for m in REFINES:
                    img, st = raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh,
                                             refine=m, workers=2, render_stats=True)
                    res[m] = [img, st.samples, []]
                for _ in range(ROUNDS):
                    for m in REFINES:
                        c = time.process_time()
                        raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, refine=m,
                                       workers=2)
                        res[m][2].append(time.process_time() - c)
                for m, (img, segs, ts) in res.items():
                    print(f"{Path(name).name.split('.')[0]:12s} {tfk:6s} {sh:5s} refine {m} "
                          f"cpu {1e3 * min(ts):6.1f} ms  segments {segs / 1e6:5.2f} M  "
                          f"{1e9 * min(ts) / segs:5.1f} ns/segment  PSNR {psnr(img, ref):5.1f} dB",
                          flush=True)


if __name__ == "__main__":
    main()
