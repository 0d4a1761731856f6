"""Which predictfit flags the lossy cells that reach predictfit decode with: printed after
the data, shape, lo, hi, mask, fill, low, tex, mix, local, plane. PYTHONPATH=<tree>."""
import sys

import numpy as np

sys.path.insert(0, "scripts")
import datasets

from volpack import api
from volpack.volume_codec import predictfit

orig = predictfit.decode
def spy(*a, **k):
    print("  predictfit.decode", [x if not hasattr(x, "shape") else x.shape for x in a[1:]], {kk: vv for kk, vv in k.items()})
    return orig(*a, **k)
predictfit.decode = spy
for name, rel in [("mri_piesno_noise", 1e-3), ("mri_piesno_noise", 1e-5), ("hgt_500", 1e-5), ("storm_p", 1e-5)]:
    a = np.ascontiguousarray(datasets.load(name)[0])
    e = float(f"{(float(a.max()) - float(a.min())) * rel:.4g}")
    b = bytes(api.compress_array(a, max_error=e))
    print(name, rel)
    api.decompress_array(b)
