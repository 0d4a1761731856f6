"""Digest of the default bounded stream of 3-D corpus fields (and the trial's 2-D slices)
at two bounds: run once with the old code on PYTHONPATH (git archive 10dcf4d) and once
with this branch, and compare the printed lines.

Run: PYTHONPATH=DIR python results/lossy/flat34/same_bytes.py > OUT.txt
"""

import hashlib
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
from datasets import load  # noqa: E402

from volpack import api  # noqa: E402

FIELDS = ("cam_t", "climate_rh", "hgt_500", "sea_ice", "tgv_u", "mri_inia19_float", "sst_monthly",
          "xray_1jzv")  # fmt: skip
for name in FIELDS:
    v = np.asarray(load(name)[0])
    m = v.shape[0] // 2
    for kind, a in (("3d", v), ("slice", v[m : m + 1]), ("slab4", v[m - 2 : m + 2])):
        a = np.ascontiguousarray(a)
        for rel in (1e-2, 1e-4):
            b = api.compress_array(a, rel_error=rel, workers=2)
            print(name, kind, rel, len(b), hashlib.sha256(b).hexdigest()[:16], flush=True)
