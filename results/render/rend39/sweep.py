"""What the opaque frames' refinement and termination buy (session 39, rend39; issue 22).

    PYTHONPATH=. python results/render/rend39/sweep.py VOLUME ... > results/render/rend39/sweep.txt

The peers benchmark's first view (azimuth 30, 512^2, step 0.5, opaque TF), one thread,
CPU ms best of ROUNDS (variants interleaved), segments, PSNR against the default
step-0.125 image (what the benchmark scores). Variants move knobs read at render time
(no kernel changes): REFINE_OPACITY, ``refine``, ``ert`` (``--knobs``, the base code),
REFINE_GAIN (the default set; ``tried_refine_gain.diff`` applied) and REFINE_STRAIGHT
(``--straight``; ``tried_refine_straight.diff`` applied).
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load, psnr  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import interleaved_cpu, knobs  # noqa: E402

from volpack.render import raycast as rc  # noqa: E402
from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

ROUNDS = 5
VARIANTS = {  # name: (module knobs, render kwargs)
    "base": ({}, {}),
    "gain 1/2048": ({"REFINE_GAIN": 1 / 2048}, {}),
    "gain 1/512": ({"REFINE_GAIN": 1 / 512}, {}),
    "gain 1/128": ({"REFINE_GAIN": 1 / 128}, {}),
    "refop 0.2": ({"REFINE_OPACITY": 0.2, "REFINE_GAIN": 0.0}, {}),
    "refine 1": ({}, {"refine": 1}),
}
if len(sys.argv) > 1 and sys.argv[1] == "--straight":  # segments left unrefined
    sys.argv.pop(1)
    VARIANTS = {
        "base": ({"REFINE_STRAIGHT": 0.0}, {}),
        "straight .05": ({"REFINE_STRAIGHT": 0.05}, {}),
        "straight .1": ({"REFINE_STRAIGHT": 0.1}, {}),
        "straight .25": ({"REFINE_STRAIGHT": 0.25}, {}),
        "straight .5": ({"REFINE_STRAIGHT": 0.5}, {}),
        "refine 1": ({}, {"refine": 1}),
    }
if len(sys.argv) > 1 and sys.argv[1] == "--knobs":  # the first sweep (refinement, ert)
    sys.argv.pop(1)
    VARIANTS = {
        "base": ({}, {}),
        "refop 0.2": ({"REFINE_OPACITY": 0.2}, {}),
        "refop 0.3": ({"REFINE_OPACITY": 0.3}, {}),
        "refop 0.5": ({"REFINE_OPACITY": 0.5}, {}),
        "refine 2": ({}, {"refine": 2}),
        "refine 1": ({}, {"refine": 1}),
        "ert 0.98": ({}, {"ert": 0.98}),
        "ert 0.95": ({}, {"ert": 0.95}),
    }


def main(args):
    shadings = ["none", "phong"]
    tfk = "opaque"
    if args and args[0].startswith("--tf="):
        tfk = args.pop(0)[5:]
    names = {a for values, _ in VARIANTS.values() for a in values}
    defaults = {a: getattr(rc, a) for a in names}  # a tried knob needs its diff applied
    for name in args:
        vol, sp = load(name)
        prep = prepare_volume(vol, sp)
        tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
        cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
        nm = Path(name).stem.split(".")[0]
        for sh in shadings:
            ref = rc.render(prep, tf=tf, camera=cam, step=0.125, shading=sh, workers=2)
            res = {}

            def go(k, stats=False, prep=prep, tf=tf, cam=cam, sh=sh):
                values, kw = VARIANTS[k]
                with knobs(rc, {**defaults, **values}):
                    return rc.render(prep, tf=tf, camera=cam, step=0.5, shading=sh, workers=1,
                                     render_stats=stats, **kw)  # fmt: skip

            for k in VARIANTS:
                img, st = go(k, True)
                res[k] = [psnr(img, ref), st.samples, []]
            for k, ts in interleaved_cpu({k: lambda k=k: go(k) for k in VARIANTS},
                                         ROUNDS).items():  # fmt: skip
                res[k][2] = ts
            b = min(res["base"][2])
            for k, (p, n, ts) in res.items():
                print(f"{nm:12s} {tfk:6s} {sh:5s} {k:12s} cpu {min(ts) * 1e3:7.1f} ms "
                      f"({min(ts) / b:.3f}x)  segments {n / 1e6:6.2f} M  PSNR {p:6.2f} dB",
                      flush=True)  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1:])
