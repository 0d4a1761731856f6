"""CPU ms a frame of turb (or FIELD) with variants set by module attributes, interleaved,
best of ROUNDS. Usage: python ab.py FIELD TF SHADING 'name:attr=val,attr=val' ...
(attr of volpack.render.raycast; 'brick=N' replaces brick_size, kw_NAME=V passes
NAME=V to render). Env: WORKERS (2), ROUNDS (5); run with PYTHONPATH=<worktree>
so that the worktree's volpack is imported. AB_*, CLEAR_RUN, LAZY_FRONT: flags of
tried_clear_run_lazy_front.diff (not in the code)."""
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import bench_render_peers as b

from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.transfer import TransferFunction

name, tfk, sh = sys.argv[1:4]
variants = []
for spec in sys.argv[4:]:
    label, _, kv = spec.partition(":")
    variants.append((label, dict(p.split("=") for p in kv.split(",") if p)))
vol, sp = b.load_warm(name, 2)
prep = prepare_volume(vol, sp)
tf = TransferFunction(points=b.tf_points(tfk, *b.tf_base(vol)))
orig = {k: getattr(raycast, k) for k in dir(raycast)}
orig_bs = raycast.brick_size
KW = {}


def setv(kv):
    for k, v in kv.items():
        if k.startswith("kw_"):
            KW[k[3:]] = eval(v)
        elif k == "brick":
            raycast.brick_size = lambda s, v=int(v): v
        else:
            setattr(raycast, k, type(orig[k])(eval(v)))


def reset():
    KW.clear()
    raycast.brick_size = orig_bs
    for k in ("REFINE_OPACITY", "REFINE", "REFINE_BEND", "NEAREST"):
        setattr(raycast, k, orig[k])
    for k in [k for k in dir(raycast) if k.startswith("AB_")]:
        setattr(raycast, k, orig[k])




def cam(az):
    return Camera(azimuth=az, elevation=b.ELEVATION, size=(512, 512))


k = dict(classification="preintegrated", shading=sh, workers=int(__import__("os").environ.get("WORKERS", 2)))
ref = raycast.render(prep, tf=tf, camera=cam(30.0), step=0.125, **k)[..., :3]
imgs, best, segs = {}, {}, {}
for label, kv in variants:
    setv(kv)
    img, st = raycast.render(prep, tf=tf, camera=cam(30.0), render_stats=True, **k, **KW)
    imgs[label], segs[label] = img, st.samples
    reset()
for _rnd in range(int(__import__("os").environ.get("ROUNDS", 5))):
    for label, kv in variants:
        setv(kv)
        c = time.process_time()
        for az in (40.0, 50.0, 60.0):
            raycast.render(prep, tf=tf, camera=cam(az), **k, **KW)
        t = (time.process_time() - c) / 3
        best[label] = min(best.get(label, 9), t)
        reset()
base = variants[0][0]
for label, _ in variants:
    d = np.abs(imgs[label] - imgs[base]).max()
    print(f"{Path(name).stem} {tfk} {sh} {label:12s} cpu {best[label]*1000:6.1f} ms "
          f"x{best[label]/best[base]:.3f}  segs {segs[label]:,}  psnr {b.psnr(imgs[label][..., :3], ref):.2f}"
          f"  maxdiff {d:.2e}", flush=True)
