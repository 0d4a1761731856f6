"""Where a small volume's frame goes (session 36, helper rend36; issue 22).

    PYTHONPATH=. python results/render/rend36/probe.py VOLUME [VOLUME ...] [--tf opaque] [--shading none]

For each volume, the peers benchmark's scene (its TF, 512x512, step 0.5, orbit views
10 degrees apart, elevation 20), CPU (process time, all threads) and wall per frame, best
of 5 views, on 2 threads unless said, for variants that each differ in one thing:

* ``default``: the frame as the benchmark times it;
* ``1x1``: a 1 x 1 image (the per-frame Python and table work alone);
* ``clear``: a TF with zero opacity everywhere (every brick empty: rays that hit the
  box cost their set-up and one empty-space test);
* ``zoom0.25``: the volume in a quarter of the field (most rays miss the box);
* ``refine1``, ``noskip``, ``1thread``.

Prints samples a frame, rays that hit the box, and ns a sample.
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import bench_render_peers as b  # noqa: E402

from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.raycast import render  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402


def load(name):
    vol, sp = b.load_warm(name, 2)
    return vol, sp


def box_hits(prep, cam):
    """Rays that hit the volume's box (a render with a TF opaque everywhere, ert 0)."""
    tf = np.ones((256, 4), np.float32)
    img = render(prep, tf=tf, camera=cam, step=4.0, skip_empty=False, workers=2, refine=1)
    return int(np.count_nonzero(img[..., 3] > 0))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("volumes", nargs="+")
    ap.add_argument("--tf", default="opaque")
    ap.add_argument("--shading", default="none")
    ap.add_argument("--variants", nargs="+",
                    default=["default", "1x1", "clear", "zoom0.25", "refine1", "noskip", "1thread"])
    a = ap.parse_args()
    for name in a.volumes:
        vol, sp = load(name)
        tf = TransferFunction(points=b.tf_points(a.tf, *b.tf_base(vol)))
        clear = TransferFunction(points=[(float(np.nanmin(vol)), 0, 0, 0, 0), (float(np.nanmax(vol)), 1, 1, 1, 0)])
        prep = prepare_volume(vol, sp)
        hits = box_hits(prep, Camera(azimuth=40, elevation=20, size=(512, 512)))
        label = Path(name).name.split(".")[0]
        print(f"{label} {vol.shape} {vol.dtype} sp {tuple(round(s, 3) for s in sp)}: {hits} rays hit the box", flush=True)
        for var in a.variants:
            kw = {"workers": 2, "tf": tf}
            size, zoom = (512, 512), 1.0
            if var == "1x1":
                size = (1, 1)
            elif var == "clear":
                kw["tf"] = clear
            elif var == "zoom0.25":
                zoom = 0.25
            elif var == "refine1":
                kw["refine"] = 1
            elif var == "noskip":
                kw["skip_empty"] = False
            elif var == "1thread":
                kw["workers"] = 1
            best, bestw = 9.0, 9.0
            for az in (40, 50, 60, 40, 50):
                cam = Camera(azimuth=az, elevation=b.ELEVATION, size=size, zoom=zoom)
                t, w = time.process_time(), time.perf_counter()
                img, st = render(prep, camera=cam, step=0.5, classification="preintegrated",
                                 shading=a.shading, render_stats=True, **kw)
                best = min(best, time.process_time() - t)
                bestw = min(bestw, time.perf_counter() - w)
            ns = best / st.samples * 1e9 if st.samples else float("nan")
            print(f"  {label:10s} {a.tf} {a.shading:5s} {var:9s} cpu {best * 1e3:6.1f} ms wall {bestw * 1e3:6.1f} ms"
                  f"  samples {st.samples / 1e6:5.2f} M  lit px {st.hits:6d}  {ns:5.1f} ns/sample", flush=True)


if __name__ == "__main__":
    main()
