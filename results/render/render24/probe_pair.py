"""Pair cost with the pipelined run: _near_run alone against _near_run plus a second,
free-running ray one voxel over (its own samples, look-ups, compositing)."""
import inspect, sys, time, textwrap, os
import numpy as np
sys.path.insert(0, "scripts")
from volpack import _jit
import bench_render_peers as peers, datasets
from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

SRC = textwrap.dedent(inspect.getsource(raycast._near_run.py_func))
MSRC = textwrap.dedent(inspect.getsource(raycast._march))
SPEC = textwrap.dedent(inspect.getsource(raycast._march_specialised))

def variant(edits):
    src = SRC
    for a, b in edits:
        assert a in src, a
        src = src.replace(a, b)
    _jit.CACHE = False; _jit._KERNEL_CACHE = None
    ns = dict(vars(raycast))
    exec(compile(src, "<run>", "exec"), ns)
    pass
    exec(compile(MSRC, "<m>", "exec"), ns)
    ns["_march_inline"] = raycast.kernel(ns["_march"], inline=True)
    exec(compile(SPEC, "<spec>", "exec"), ns)
    return ns["_march_specialised"](True, 0)

PAIR = [("    jn = _nearest(xn, n_tab)\n    while i < end:",
         "    jn = _nearest(xn, n_tab)\n    qx = min(px + (1 << 24), (np.int64(vol.shape[2] - 2) << 24))\n    xq = interior_sample(vol, pz, py, qx) * vs + v0\n    jq = _nearest(xq, n_tab)\n    iq = ii\n    br = bg = bb = ba = 0.0\n    while i < end:"),
        ("            jn = _nearest(xn, n_tab)\n",
         "            jn = _nearest(xn, n_tab)\n            qx = min(px + (1 << 24), (np.int64(vol.shape[2] - 2) << 24))\n            xq2 = interior_sample(vol, pz, py, qx) * vs + v0\n        jq2 = jq\n        if i + 1 < end:\n            jq = _nearest(xq2, n_tab)\n        a2 = pre2d[iq, jq2, 3]\n        if a2 > 0.0:\n            w2 = 1.0 - ba\n            br, bg, bb, ba = br + w2 * pre2d[iq, jq2, 0], bg + w2 * pre2d[iq, jq2, 1], bb + w2 * pre2d[iq, jq2, 2], ba + w2 * a2\n        iq = jq2\n"),
        ("    return i, ii, xf, ar, ag, ab, aa, False", "    return i, ii, xf, ar + 1e-300 * (br + bg + bb + ba), ag, ab, aa, False")]
name = sys.argv[1]
vol, sp, _ = datasets.load(name)
sp = tuple(float(s) for s in sp)
tf = TransferFunction(points=peers.tf_points("semi", *peers.tf_base(vol)))
prep = prepare_volume(vol, sp)
kern = {"run": variant([]), "pair": variant(PAIR)}
res = {k: [] for k in kern}
for rnd in range(4):
    for k in kern:
        raycast._MARCH[True, 0] = kern[k]
        for j in range(3):
            cam = Camera(azimuth=40.0 + 10 * j, elevation=20.0, size=(512, 512))
            c = time.process_time()
            img, st = render(prep, tf=tf, camera=cam, step=0.5, workers=1, render_stats=True)
            if rnd:
                res[k].append(time.process_time() - c)
for k in kern:
    print(name, k, f"best {min(res[k])*1e3:.1f} ms median {np.median(res[k])*1e3:.1f} ms")
