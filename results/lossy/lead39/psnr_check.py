"""A PSNR target's file as a user gets it: bits a voxel, the PSNR decoded (peak: the
valid range) and the largest error, for each target given.

    PYTHONPATH=<checkout> python results/lossy/lead39/psnr_check.py FIELD.npy 40 60 80
"""
import numpy as np, math, io, sys, time
from volpack.volume_codec.stream import compress
from volpack import api
a = np.load(sys.argv[1]); rng = float(np.nanmax(a) - np.nanmin(a))
for kw in [dict(psnr=float(p)) for p in sys.argv[2:]]:
    t = time.time(); buf = io.BytesIO(); m = compress(a, buf, **kw); b = buf.getvalue()
    d = api.decompress_array(b); err = d.astype(np.float64) - a
    ps = 10 * math.log10(rng**2 / (err**2).mean())
    print(f"{sys.argv[1].split('/')[-1]} {kw} bpv {len(b)*8/a.size:.4f} psnr {ps:.2f} maxerr {np.abs(err).max():.3e} {time.time()-t:.1f}s", flush=True)
