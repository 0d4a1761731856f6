"""Compile cost of the inlined refinement (session 39, rend39): a first unshaded opaque
render of a 24^3 uint8 volume on an empty kernel cache (everything it compiles).

    d=$(mktemp -d); VOLPACK_CACHE_DIR=$d PYTHONPATH=. python results/render/rend39/compile_time.py

run alternately on the final code and with ``_refined_plain``'s decorator set back to
``@kernel(nrt=False, contract=True)`` (the base), a fresh cache directory each time.
"""

import time

import numpy as np

from volpack.render.camera import Camera
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

vol = (np.random.default_rng(0).random((24, 24, 24)) * 255).astype(np.uint8)
tf = TransferFunction(points=((100, 0, 0, 0, 0), (150, 0.9, 0.7, 0.6, 0.9), (255, 1, 1, 1, 1)))
t0 = time.perf_counter()
for sh in ("none",):
    render(vol, tf=tf, camera=Camera(size=(32, 32)), shading=sh, workers=1)
print(f"first unshaded render (compiles) {time.perf_counter() - t0:.1f} s")
