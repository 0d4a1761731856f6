# ruff: noqa: E402  (the compile listener is registered before volpack is imported)
"""After `volpack warmup` on a fresh cache: what a user's first commands still compile.

Run from the repository root: ``VOLPACK_CACHE_DIR=DIR volpack warmup`` on an empty DIR,
then ``VOLPACK_CACHE_DIR=DIR python results/warmup27/probe.py`` (needs
``python scripts/fetch_data.py`` and ``results/unseen26/make.py``'s shock.npy in
/work/lead/unseen: edit SHOCK below)."""

import sys
import time

import numpy as np

sys.path.insert(0, "scripts")
from numba.core import event

names = []


class L(event.Listener):
    def on_start(self, ev):
        names.append(getattr(ev.data.get("dispatcher"), "py_func", None).__name__)

    def on_end(self, ev):
        pass


event.register("numba:compile", L())
import bench_render_peers as b
from datasets import load

from volpack import api
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

vols = {n: load(n)[0] for n in ("ct_head", "mri_ch2", "mri_dipy_s0", "tgv_vorticity", "storm_u")}
SHOCK = "/work/lead/unseen/shock.npy"
vols["shock"] = np.load(SHOCK)
total = 0
for n, a in vols.items():
    a = a[:64, :96, :96] if a.size > 64 * 96 * 96 else a
    for name, kw in (
        ("lossless", {}),
        ("fast", {"codec": "fast"}),
        ("lossy1e-3", {"rel_error": 1e-3}),
        ("lossy1e-5", {"rel_error": 1e-5}),
        ("lossyfast1e-3", {"rel_error": 1e-3, "effort": "fast"}),
    ):
        if np.issubdtype(a.dtype, np.floating) and name == "fast":
            continue
        k = len(names)
        t = time.time()
        try:
            api.decompress_array(api.compress_array(a, **kw))
        except Exception as e:
            print(n, name, "error", e)
            continue
        new = sorted(set(names[k:]))
        total += len(names) - k
        print(n, a.dtype, name, f"{time.time() - t:.1f}s", new[:8], len(names) - k, flush=True)
    lo, hi = b.tf_base(a)
    k = len(names)
    t = time.time()
    for kind in ("semi", "opaque"):
        for shade in ("none", "phong"):
            render(
                prepare_volume(a, (1.0, 1.0, 1.0)),
                tf=TransferFunction(points=b.tf_points(kind, lo, hi)),
                camera=Camera(azimuth=30, elevation=20, size=(256, 256)),
                step=0.5,
                shading=shade,
                workers=2,
            )
    new = sorted(set(names[k:]))
    total += len(names) - k
    print(n, a.dtype, "render", f"{time.time() - t:.1f}s", new[:8], len(names) - k, flush=True)
print("total compiles", total)
