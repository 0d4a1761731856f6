"""Where a fill value's frames go, and the tables narrowed to the TF against the data
range, in one process (session 37, helper rend37; issue 22).

    PYTHONPATH=. python results/render/rend37/probe.py [volume ...] > results/render/rend37/probe.txt

For each volume, the peers benchmark's TFs (semi, opaque) and shadings, at the benchmark's
first view (azimuth 30, 512^2, step 0.5, 2 threads): ``NARROW_SHARE = 0`` (the tables over
the data range, as before session 37) and the default (narrowed when the TF's points cover
less than a quarter of it). Prints CPU ms a frame (best of ``ROUNDS``, the two settings
interleaved), segments a frame, PSNR against the same setting's step-0.125 image
(what the benchmark scores) and against a *truth*: post-classified point samples at
step 1/32 through a 4096-entry table over the TF's points (post-classification reads
the TF's value at each sample, exact beyond the table's ends, where the TF is constant).
"""

import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import bench_render_peers as peers  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 5
SETTINGS = {"data range": 0.0, "narrowed": raycast.NARROW_SHARE}


def load(name):
    """The volume and spacing, as the benchmark reads them (no warm-up: only the kernels
    these renders use compile, outside the timings, in the first render of each)."""
    if Path(name).is_file():
        from volpack.api import read_volume

        v = read_volume(name)
        return v.data, tuple(float(s) for s in v.spacing)
    import datasets

    vol, sp, _ = datasets.load(name)
    return vol, tuple(float(s) for s in sp)


def psnr(a, b):
    mse = float(np.mean((a[..., :3].astype(np.float64) - b[..., :3]) ** 2))
    return 99.0 if mse == 0 else 10 * math.log10(1.0 / mse)


def main(names):
    for name in names:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        for tfk in ("semi", "opaque"):
            pts = peers.tf_points(tfk, *peers.tf_base(vol))
            tf = TransferFunction(points=pts)
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            raycast.NARROW_SHARE = 1.0  # the truth: tables over the TF's points
            truth = raycast.render(prep, tf=tf, camera=cam, step=1 / 32, classification="post",
                                   table_size=4096, workers=2)
            for sh in ("none", "phong"):
                res = {}
                for k, share in SETTINGS.items():
                    raycast.NARROW_SHARE = share
                    ref = raycast.render(prep, tf=tf, camera=cam, step=0.125, shading=sh, workers=2)
                    img, st = raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh,
                                             workers=2, render_stats=True)
                    res[k] = [img, ref, st.samples, []]
                for _ in range(ROUNDS):
                    for k, share in SETTINGS.items():
                        raycast.NARROW_SHARE = share
                        c = time.process_time()
                        raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                        res[k][3].append(time.process_time() - c)
                for k, (img, ref, segs, ts) in res.items():
                    tt = psnr(img, truth) if sh == "none" else float("nan")
                    print(f"{Path(name).name.split('.')[0]:14s} {tfk:6s} {sh:5s} {k:10s} "
                          f"cpu {1e3 * min(ts):7.1f} ms  segments {segs / 1e6:6.2f} M  "
                          f"PSNR own ref {psnr(img, ref):5.1f} dB  vs truth {tt:5.1f} dB", flush=True)
            raycast.NARROW_SHARE = SETTINGS["narrowed"]


if __name__ == "__main__":
    main(sys.argv[1:] or ["storm_u", str(ROOT / "results/render/rend37/vols/smooth_fill.npy")])
