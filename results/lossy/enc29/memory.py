"""Peak RSS of one lossy encode of a 128^3 float32 brick, and what the wavelet scan caches
hold after it (each cached scan of a 128^3 brick: 25 bytes a voxel).

    PYTHONPATH=. python results/lossy/enc29/memory.py /work/lead/s29/big/s128.npy
"""

import resource
import sys

import numpy as np

from volpack import api
from volpack.wavelet import packet, sigmap

x = np.load(sys.argv[1])
print("rss0", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024, "MB")
api.compress_array(x, max_error=1e-3 * float(x.max() - x.min()))
print("rss1", resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024, "MB")
print(sigmap.scan.cache_info(), packet.scan.cache_info())
held = sigmap.scan.cache_info().currsize + packet.scan.cache_info().currsize
print("scan MB", held * x.size * 25 / 1e6)
