import hashlib
import sys

sys.path.insert(0, "scripts")
import datasets
import numpy as np

from volpack import api

for name, rel in (("ct_head", 1e-3), ("mri_inia19_float", 1e-3), ("md_water", 1e-4)):
    a = np.ascontiguousarray(datasets.load(name)[0])
    e = float(f"{(float(a.max()) - float(a.min())) * rel:.4g}")
    b1 = api.compress_array(a, max_error=e, effort="fast", workers=1)
    b2 = api.compress_array(a, max_error=e, effort="fast", workers=2)
    d1 = api.decompress_array(b1, workers=1)
    d2 = api.decompress_array(b1, workers=2)
    print(
        name,
        "bytes 1==2 workers",
        b1 == b2,
        "decode 1==2",
        np.array_equal(d1, d2),
        "max err ok",
        float(np.abs(d1.astype(np.float64) - a).max()) <= e,
        hashlib.sha256(d1.tobytes()).hexdigest()[:16],
    )
