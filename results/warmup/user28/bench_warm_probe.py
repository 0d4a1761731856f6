# ruff: noqa: E402  (the compile subscriber is registered before a kernel is loaded)
"""Which kernels compile inside bench_render_peers' timed volpack frames after its
warm_up, on an empty kernel cache.

Run from the repository root, on an empty DIR each time:
``VOLPACK_CACHE_DIR=DIR python results/warmup/user28/bench_warm_probe.py SIZE [VOLUMES]``
(default: the benchmark's three volumes; SIZE the frames' side, the benchmark's 512 or
256 with --quick). Each case renders as the benchmark's Volpack renderer does:
preintegrated and post at step 0.5, preintegrated at 1 voxel and at the reference's
0.125, x the semi/opaque transfer functions x unshaded/Phong, two threads. (The logs of
session 28 were made with numba's compile event listened to directly, as
results/warmup27/probe.py does, and without PYTHONPATH for the first, 64-pixel one:
/work/main's volpack of that time, the base's renderer.)"""

import sys
import time

sys.path.insert(0, "scripts")
from volpack import jitwatch

names = []  # kernels compiled (volpack forwards numba's compile events to jitwatch)
jitwatch.subscribe(lambda event, name, _: names.append(name) if event == "start" else None)
import bench_render_peers as b
import datasets
import numpy as np

from volpack import _jit

print("cache", _jit.cache_dir(), flush=True)
total = 0
SIZE = int(sys.argv[1])
for name in sys.argv[2:] or b.VOLUMES:
    if name.endswith(".npy"):  # a volume of results/unseen26/make.py (shock.npy)
        vol, spacing = np.load(name), (1.0, 1.0, 1.0)
    else:
        vol, spacing, _ = datasets.load(name)
    spacing = tuple(float(s) for s in spacing)
    t = time.time()
    b.warm_up(vol, spacing, 2)
    print(f"{name} {vol.dtype} warm_up {time.time() - t:.1f}s, {len(names)} compiled", flush=True)
    for tfk in ("semi", "opaque"):
        for shade in (False, True):
            for cls, step in (("preintegrated", 0.5), ("post", 0.5), ("preintegrated", 1.0),
                              ("preintegrated", 0.125)):  # fmt: skip
                k = len(names)
                r = b.Volpack(vol, spacing, b.tf_points(tfk, *b.tf_base(vol)), shade, 2, SIZE,
                              step, cls)  # fmt: skip
                r.frame(30.0)
                r.frame(40.0)
                if len(names) > k:
                    total += len(names) - k
                    print(f"  {name} {tfk} {'phong' if shade else 'none'} {cls} {step}: "
                          f"compiled {sorted(set(names[k:]))}", flush=True)  # fmt: skip
print("compiled inside the frames:", total)
