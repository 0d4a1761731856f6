"""Where bonsai's and engine's opaque frames go (session 38, rend38; issue 22): CPU ms a
frame (best of ROUNDS, settings interleaved), segments a frame, empty bricks and PSNR
against the default's step-0.125 image, for empty-space bricks of 4^3 (today) and
2^3, at the peers benchmark's first view (azimuth 30, 512^2, step 0.5, 2 threads).

    PYTHONPATH=. python results/render/rend38/probe_brick.py VOLUME ... [--tfs opaque]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

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
_LEAP = raycast._leap_kernel


def eroded(k):
    """A leap kernel that keeps as empty only bricks at Chebyshev distance >= k from a
    visible one (k = 1: today's)."""

    def run(empty, out):
        _LEAP(empty, out)
        if k > 1:
            e2 = np.ascontiguousarray(out >= k)
            _LEAP(e2, out)

    return run


def setting(key):
    """'4', '2', '2e2' (2^3 bricks, empties eroded to distance >= 2)."""
    b, _, k = key.partition("e")
    raycast.FINE_BRICK = int(b)
    raycast._leap_kernel = eroded(int(k or 1))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--tfs", nargs="+", default=["opaque"])
    ap.add_argument("--bricks", nargs="+", default=["4", "2", "2e2"])
    ap.add_argument("--shadings", nargs="+", default=["none", "phong"])
    a = ap.parse_args()
    for name in a.volumes:
        vol, sp = load(name)
        preps = {b: prepare_volume(vol, sp) for b in a.bricks}
        for tfk in a.tfs:
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            for sh in a.shadings:
                setting("4")
                ref = raycast.render(
                    preps["4"], tf=tf, camera=cam, step=0.125, shading=sh, workers=2
                )
                res = {}
                for b in a.bricks:
                    setting(b)
                    img, st = raycast.render(
                        preps[b],
                        tf=tf,
                        camera=cam,
                        step=0.5,
                        shading=sh,
                        workers=2,
                        render_stats=True,
                    )
                    res[b] = [img, st.samples, []]
                for _ in range(ROUNDS):
                    for b in a.bricks:
                        setting(b)
                        c = time.process_time()
                        raycast.render(preps[b], tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                        res[b][2].append(time.process_time() - c)
                setting("4")
                for b, (img, segs, ts) in res.items():
                    print(
                        f"{Path(name).name.split('.')[0]:12s} {tfk:6s} {sh:5s} brick {b:4s} "
                        f"cpu {1e3 * min(ts):6.1f} ms  segments {segs / 1e6:5.2f} M  "
                        f"{1e9 * min(ts) / segs:5.1f} ns/segment  PSNR {psnr(img, ref):5.1f} dB",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
