"""A/B of the ray caster in one process (session 39, rend39 (rend38's ab.py, unchanged but the name); issue 22): the base
code's ``raycast`` (a copy at ``volpack/render/_raycast_base.py``, made for the run and
removed after it) against the worktree's, frames interleaved round by round; CPU ms a
frame (best of ROUNDS), segments, whether the images are equal bit for bit and PSNR
against the step-0.125 image, at the peers benchmark's first view (azimuth 30, 512^2,
step 0.5, 2 threads).

    cp <base raycast.py> volpack/render/_raycast_base.py
    PYTHONPATH=. python results/render/rend39/ab.py VOLUME ... [--tfs opaque]
"""

import argparse
import importlib
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--tfs", nargs="+", default=["opaque"])
    ap.add_argument("--shadings", nargs="+", default=["none", "phong"])
    ap.add_argument(
        "--leap-min",
        nargs="+",
        type=int,
        default=[],
        help="also the new code at these LEAP_MIN values",
    )
    a = ap.parse_args()
    base = importlib.import_module("volpack.render._raycast_base")
    keys = {"base": (base, None), "new": (raycast, None)}
    keys.update({f"new{j}": (raycast, j) for j in a.leap_min})
    default_jmin = getattr(raycast, "LEAP_MIN", 1)
    for name in a.volumes:
        vol, sp = load(name)
        for tfk in a.tfs:
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            for sh in a.shadings:
                preps = {k: prepare_volume(vol, sp) for k in keys}
                ref = base.render(
                    preps["base"], tf=tf, camera=cam, step=0.125, shading=sh, workers=2
                )
                res = {}
                for k, (m, j) in keys.items():
                    raycast.LEAP_MIN = default_jmin if j is None else j
                    img, st = m.render(
                        preps[k],
                        tf=tf,
                        camera=cam,
                        step=0.5,
                        shading=sh,
                        workers=2,
                        render_stats=True,
                    )
                    res[k] = [img, st.samples, []]
                for _ in range(ROUNDS):
                    for k, (m, j) in keys.items():
                        raycast.LEAP_MIN = default_jmin if j is None else j
                        c = time.process_time()
                        m.render(preps[k], tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                        res[k][2].append(time.process_time() - c)
                raycast.LEAP_MIN = default_jmin
                tb = min(res["base"][2])
                for k in keys:
                    if k == "base":
                        continue
                    same = np.array_equal(res["base"][0], res[k][0])
                    tn = min(res[k][2])
                    print(
                        f"{Path(name).name.split('.')[0]:12s} {tfk:6s} {sh:5s} {k:5s} cpu base "
                        f"{1e3 * tb:6.1f} new {1e3 * tn:6.1f} ms  x{tn / tb:5.3f}  segments "
                        f"{res['base'][1] / 1e6:5.2f} -> {res[k][1] / 1e6:5.2f} M  same image "
                        f"{same}  PSNR {psnr(res['base'][0], ref):5.1f} -> "
                        f"{psnr(res[k][0], ref):5.1f} dB",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
