"""The s128 field at 1e-3 of its range (one 128^3 brick, default effort, one worker): the
bytes against the file session 29 wrote (/work/lead/s29/big/s128_1e3.bin).

    PYTHONPATH=. python results/lossy/mem30/same_s128.py
"""

import sys

import numpy as np

import volpack
from volpack import api

print(volpack.__file__, file=sys.stderr)
x = np.load("/work/lead/s29/big/s128.npy")
blob = api.compress_array(x, max_error=1e-3 * float(x.max() - x.min()), workers=1)
want = open("/work/lead/s29/big/s128_1e3.bin", "rb").read()
print(len(blob), len(want), "same" if blob == want else "DIFFERENT")
