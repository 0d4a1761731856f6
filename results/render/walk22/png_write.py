import time, numpy as np, sys
from volpack.render.movie import MovieWriter
import tempfile, os
rng = np.random.default_rng(0)
img = (rng.random((512, 512, 4), dtype=np.float32) * 0.8)
d = tempfile.mkdtemp()
from volpack.render.image import ready_png; ready_png()
best = 9
for i in range(9):
    w = MovieWriter(d + f"/o{i}/", fps=25.0) if False else None
    from volpack.render.image import to_rgb8, save_rgb8
    t = time.perf_counter(); save_rgb8(os.path.join(d, f"f{i}.png"), to_rgb8(img)); best = min(best, time.perf_counter() - t)
print(f"{1e3*best:.1f}")
