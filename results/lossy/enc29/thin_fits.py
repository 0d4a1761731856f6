"""The long fit's large boxes fitted on every other z slice, against every slice (tried,
not kept: bytes +0.3-0.6 % on cam_u and tgv_pressure for 2-8 % of the time). Run on the
working tree before commit 144448f, with a switch ``lossy.THIN_FITS`` since removed:

    PYTHONPATH=. python results/lossy/enc29/thin_fits.py cam_u,tgv_pressure,climate_rh,tgv_u
"""

import sys
import time

sys.path.insert(0, "scripts")
sys.path.insert(0, "results/lossy/enc29")

import numpy as np  # noqa: E402
from bench import load_field  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402

warm = np.cumsum(np.random.default_rng(0).standard_normal((24, 24, 24)), axis=2)
for r in (1e-2, 1e-3, 1e-5):
    api.compress_array(warm.astype(np.float32), max_error=r * 40)
for name in sys.argv[1].split(","):
    x = np.load(name) if name.endswith(".npy") else load_field(name)
    for rel in (1e-3, 1e-4):
        e = rel * float(np.nanmax(x) - np.nanmin(x))
        out = []
        for thin in (False, True, False, True):
            lossy.THIN_FITS = thin
            t = time.process_time()
            n = len(api.compress_array(x, max_error=e))
            out.append((thin, n, round(time.process_time() - t, 2)))
        print(name, rel, out, flush=True)
