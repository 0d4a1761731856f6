"""A/B in one process of switches of the ray caster (session 36, rend36; issue 22).

    PYTHONPATH=. python results/render/rend36/ab.py VOLUME ... --switch BOX_SPANS [--tf opaque] [--shading none]

For each volume and case, frames of the peers benchmark's scene (512x512, step 0.5, 2
threads, orbit views 10 degrees apart) with ``raycast.<switch>`` at ``--values`` A (the old code)
and B (default 0 and 1), interleaved round by round; prints the best and median CPU ms a frame of
each, B/A, and the largest difference between the two images of each view.
"""

import argparse
import statistics
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--switch", required=True)
    ap.add_argument("--values", nargs=2, type=int, default=[0, 1],
                    help="the switch's value for A (the old code) and for B")
    ap.add_argument("--cases", nargs="+", default=["opaque:none", "opaque:phong", "semi:none"])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    old = getattr(raycast, a.switch)
    for name in a.volumes:
        vol, sp = b.load_warm(name, a.workers)
        prep = prepare_volume(vol, sp)
        label = Path(name).name.split(".")[0]
        for case in a.cases:
            tfk, shade = case.split(":")
            tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
            t = {False: [], True: []}
            diff = 0.0
            for rnd in range(a.rounds):
                for az in (40, 50, 60):
                    cam = Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512))
                    imgs = {}
                    for on in ((False, True) if rnd % 2 == 0 else (True, False)):
                        setattr(raycast, a.switch, type(old)(a.values[on]))
                        c = time.process_time()
                        imgs[on] = raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=shade,
                                                  workers=a.workers)
                        t[on].append(time.process_time() - c)
                    diff = max(diff, float(np.abs(imgs[True] - imgs[False]).max()))
            setattr(raycast, a.switch, old)
            ba, bb = min(t[False]) * 1e3, min(t[True]) * 1e3
            ma, mb = statistics.median(t[False]) * 1e3, statistics.median(t[True]) * 1e3
            print(f"{label:18s} {tfk:6s} {shade:5s} {a.switch}: A {a.values[0]} {ba:6.1f} ms (median {ma:6.1f})"
                  f"  B {a.values[1]} {bb:6.1f} ms (median {mb:6.1f})  B/A best {bb / ba:.3f} median {mb / ma:.3f}"
                  f"  max |diff| {diff:.2e}", flush=True)


if __name__ == "__main__":
    main()
