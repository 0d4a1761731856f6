"""The one held-out lossy cell below the floor (session 23): storm_u at 1e-2 of its range
(E = 100.2, the bound the benchmark rounds to 4 digits). Where volpack's bytes go, and
what the field is at that bound.

    PYTHONPATH=.:scripts python results/lossy/heldout23/diagnose_storm_u.py
"""

import numpy as np

import datasets
from volpack import api

a = datasets.load("storm_u")[0]
fill = a == -9999
print(f"fill -9999 on {fill.mean():.4f} of the voxels; the same mask in all {a.shape[0]} "
      f"time steps: {bool((fill == fill[0]).all())}; winds {a[~fill].min():.2f}..{a[~fill].max():.2f} m/s")
E = float(f"{(float(a.max()) - float(a.min())) * 1e-2:.4g}")
for effort in ("default", "max"):
    blob = api.compress_array(a, max_error=E, **({} if effort == "default" else {"effort": "max"}))
    info = api.info(blob)
    (entry,) = info["entries"]
    payload = info["payload_nbytes"]
    print(f"{effort}: E = {E}: file {len(blob)} B = header {entry['offset']} B + payload "
          f"{payload} B + {len(blob) - entry['offset'] - payload} B after it; "
          f"max error {info['max_error']:.2f}, step {info['header']['codec']['step']}")
    back = api.decompress_array(blob)
    print(f"  decoded values: {np.unique(back).size} distinct, bound held: "
          f"{bool(np.abs(back.astype(np.float64) - a).max() <= E)}")
