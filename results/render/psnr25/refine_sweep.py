"""PSNR against the benchmark's reference (step 0.125, defaults) and work of the
step-0.5 image, as refinement's sub-segment count and opacity threshold vary.

The benchmark's scene and TFs (scripts/bench_render_peers.py), pre-integrated, one
thread; CPU seconds best of 3 frames (nothing else is cleared between them, as in an
orbit); samples from RenderStats.

    python results/render/psnr25/refine_sweep.py --volumes mri_dipy_s0 ct_skull_float

``--ab``: instead, the frame time of ``refine=2`` (main's frame) against ``refine=3``,
taking turns: azimuth 40 (a later frame: tables and normals built), best CPU of
``--rounds`` per setting. Run on commit 3d8d833 (three sub-segments wherever refined,
not kept) it wrote ``ab_time.csv``; on the final code (three where the scalar bends,
the default) ``ab_time_final.csv``.
"""

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

import datasets  # noqa: E402
from bench_render_peers import ELEVATION, psnr, tf_base, tf_points  # noqa: E402

from volpack.render import raycast  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--volumes", nargs="+", default=["mri_dipy_s0", "ct_skull_float"])
    ap.add_argument("--tfs", nargs="+", default=["opaque"])
    ap.add_argument("--ab", action="store_true", help="time refine=2 against refine=3")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--settings", nargs="+", default=["2:0.1", "3:0.1", "4:0.1", "2:0.03",
                                                       "4:0.03", "2:0.01", "4:0.01"])
    args = ap.parse_args()
    if args.ab:
        return ab(args)
    print("volume,tf,shading,refine,threshold,psnr_db,samples,cpu_s")
    for name in args.volumes:
        vol, sp, _ = datasets.load(name)
        sp = tuple(float(s) for s in sp)
        prep = prepare_volume(vol, sp)
        for tfk in args.tfs:
            tf = TransferFunction(points=tf_points(tfk, *tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=ELEVATION, size=(512, 512))
            for sh in ("none", "phong"):
                raycast.REFINE_OPACITY = 0.1
                ref = raycast.render(prep, tf=tf, camera=cam, step=0.125, shading=sh,
                                     workers=1)[..., :3]
                for s in args.settings:
                    m, thr = s.split(":")
                    raycast.REFINE_OPACITY = float(thr)
                    best = 1e9
                    for _ in range(3):
                        c = time.process_time()
                        im, st = raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh,
                                                refine=int(m), workers=1, render_stats=True)
                        best = min(best, time.process_time() - c)
                    print(f"{name},{tfk},{sh},{m},{thr},{psnr(im[..., :3], ref):.2f},"
                          f"{st.samples},{best:.4f}", flush=True)
    raycast.REFINE_OPACITY = 0.1


def ab(args):
    print("volume,tf,shading,cpu_refine2_s,cpu_refine3_s,ratio,load1")
    for name in args.volumes:
        vol, sp, _ = datasets.load(name)
        prep = prepare_volume(vol, tuple(float(s) for s in sp))
        for tfk in args.tfs:
            tf = TransferFunction(points=tf_points(tfk, *tf_base(vol)))
            cam = Camera(azimuth=40.0, elevation=ELEVATION, size=(512, 512))
            for sh in ("none", "phong"):
                kw = dict(tf=tf, camera=cam, shading=sh, workers=1)
                best = {2: 1e9, 3: 1e9}
                for m in (2, 3):  # warm: the tables of both
                    raycast.render(prep, refine=m, **kw)
                for _ in range(args.rounds):
                    for m in (2, 3):
                        c = time.process_time()
                        raycast.render(prep, refine=m, **kw)
                        best[m] = min(best[m], time.process_time() - c)
                load = open("/proc/loadavg").read().split()[0]
                print(f"{name},{tfk},{sh},{best[2]:.4f},{best[3]:.4f},"
                      f"{best[3] / best[2]:.3f},{load}", flush=True)


if __name__ == "__main__":
    main()
