"""Where volpack's step-0.5 opaque image of a volume differs from its fine reference.

The benchmark's scene (scripts/bench_render_peers.py: opaque TF over [median, max],
azimuth 30, elevation 20, 512^2), volpack pre-integrated, one thread. Each variant's
step-0.5 image is scored against the benchmark's reference (step 0.125, defaults) and
against a converged one (step 1/32, table 1024, no early termination, exact normals).

    python results/render/psnr25/cause.py [--volume ct_skull_float] [--shading none phong]
"""

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))

import datasets  # noqa: E402
from bench_render_peers import ELEVATION, psnr, tf_base, tf_points  # noqa: E402

from volpack.render.camera import Camera  # noqa: E402
from volpack.render.raycast import render  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--volume", default="ct_skull_float")
    ap.add_argument("--shading", nargs="+", default=["none", "phong"])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--save", type=Path, default=None, help="save error images (npz)")
    args = ap.parse_args()
    vol, sp, _ = datasets.load(args.volume)
    sp = tuple(float(s) for s in sp)
    tf = TransferFunction(points=tf_points("opaque", *tf_base(vol)))
    cam = Camera(azimuth=30.0, elevation=ELEVATION, size=(args.size, args.size))

    def img(**kw):
        kw.setdefault("classification", "preintegrated")
        return render(vol, spacing=sp, tf=tf, camera=cam, workers=1, **kw)[..., :3]

    for sh in args.shading:
        base = dict(shading=sh)
        ref = img(step=0.125, **base)
        conv = img(step=1 / 32, table_size=1024, ert=1.0, normals="exact", **base)
        conv_q = img(step=1 / 32, table_size=1024, ert=1.0, **base)
        print(f"== {args.volume} opaque {sh}: reference (0.125) vs converged "
              f"{psnr(ref, conv):.2f} dB (quantised normals kept: {psnr(ref, conv_q):.2f})")
        variants = {
            "default (step 0.5)": dict(step=0.5),
            "step 0.25": dict(step=0.25),
            "step 0.125 ref, table 1024": dict(step=0.125, table_size=1024),
            "table 512": dict(step=0.5, table_size=512),
            "table 1024": dict(step=0.5, table_size=1024),
            "table 64": dict(step=0.5, table_size=64),
            "ert 0.999": dict(step=0.5, ert=0.999),
            "ert off": dict(step=0.5, ert=1.0),
            "refine 1": dict(step=0.5, refine=1),
            "refine 4": dict(step=0.5, refine=4),
            "exact preint": dict(step=0.5, preint_method="exact"),
        }
        if sh == "phong":
            variants["exact normals"] = dict(step=0.5, normals="exact")
        out = {}
        for name, kw in variants.items():
            im = img(**{**base, **kw})
            out[name] = im
            print(f"  {name:28s} vs ref {psnr(im, ref):6.2f}  vs converged {psnr(im, conv if kw.get('normals') == 'exact' or sh == 'none' else conv_q):6.2f}")
        post = img(step=0.5, classification="post", **base)
        postref = img(step=0.125, classification="post", **base)
        print(f"  {'post, vs its 0.125':28s} {psnr(post, postref):6.2f}")
        # where the error is: split pixels by the reference's opacity/edge
        e = np.abs(out["default (step 0.5)"].astype(np.float64) - ref).max(axis=2)
        se = ((out["default (step 0.5)"].astype(np.float64) - ref) ** 2).sum(axis=2)
        a = ref.max(axis=2)
        gy, gx = np.gradient(a)
        edge = np.hypot(gx, gy) > 0.05
        tot = se.sum()
        print(f"  error share: edge pixels {se[edge].sum() / tot:.2f} ({edge.mean():.3f} of pixels); "
              f"max abs {e.max():.3f}; pixels > 0.05: {(e > 0.05).sum()}, > 0.2: {(e > 0.2).sum()}")
        q = np.sort(se.ravel())[::-1]
        for k in (10, 100, 1000, 10000):
            print(f"    top {k:5d} pixels hold {q[:k].sum() / tot:.2f} of the squared error")
        if args.save:
            np.savez_compressed(args.save.with_name(f"{args.save.stem}_{sh}.npz"),
                                ref=ref, conv=conv, img=out["default (step 0.5)"])


if __name__ == "__main__":
    main()
