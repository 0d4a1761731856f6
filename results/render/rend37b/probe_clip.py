"""Which cut segments need their extra samples (session 37, rend37b; issue 22): the fill
volumes' frames with ``CLIP_MIN = 0`` (rend37's rule: every segment with an end beyond the
narrowed tables sampled again) against the given values (a segment whose opacity at its
end inside the tables, times the pixel's transmittance, is under it keeps its chord), in
one process, the settings interleaved round by round.

    PYTHONPATH=. python results/render/rend37b/probe_clip.py [volume ...] [--rules 0 0.00195 ...]

For each volume, the peers benchmark's TFs (semi, opaque) and shadings at its first view
(azimuth 30, 512^2, step 0.5, 2 threads): CPU ms a frame (best of ``ROUNDS``), segments a
frame, PSNR against rend37's step-0.125 image (``CLIP_MIN = 0``, what the benchmark
scored) and, unshaded, against the truth of rend37's probe (post-classified point
samples at step 1/32 through a 4096-entry table over the TF's points).
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


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rules", nargs="+", type=float, default=[0.0, raycast.CLIP_MIN],
                    help="CLIP_MIN values")
    ap.add_argument("--tfs", nargs="+", default=["semi", "opaque"])
    ap.add_argument("--shadings", nargs="+", default=["none", "phong"])
    ap.add_argument("volumes", nargs="*", default=["storm_u"])
    a = ap.parse_args()
    rules = a.rules
    for name in a.volumes:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        for tfk in a.tfs:
            tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
            cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
            raycast.CLIP_MIN = 0.0
            share = raycast.NARROW_SHARE
            raycast.NARROW_SHARE = 1.0
            truth = raycast.render(prep, tf=tf, camera=cam, step=1 / 32, classification="post",
                                   table_size=4096, workers=2)
            raycast.NARROW_SHARE = share
            for sh in a.shadings:
                raycast.CLIP_MIN = 0.0
                ref = raycast.render(prep, tf=tf, camera=cam, step=0.125, shading=sh, workers=2)
                res = {}
                for rule in rules:
                    raycast.CLIP_MIN = rule
                    img, st = raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh,
                                             workers=2, render_stats=True)
                    res[rule] = [img, st.samples, []]
                for _ in range(ROUNDS):
                    for rule in rules:
                        raycast.CLIP_MIN = rule
                        c = time.process_time()
                        raycast.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, workers=2)
                        res[rule][2].append(time.process_time() - c)
                for cmin, (img, segs, ts) in res.items():
                    tr = f"{psnr(img, truth):5.1f}" if sh == "none" else "  -  "
                    print(f"{Path(name).name.split('.')[0]:12s} {tfk:6s} {sh:5s} CLIP_MIN {cmin:7.5f} "
                          f"cpu {1e3 * min(ts):6.1f} ms  segments {segs / 1e6:5.2f} M  "
                          f"PSNR ref {psnr(img, ref):5.1f} dB  truth {tr} dB", flush=True)


if __name__ == "__main__":
    main()
