"""Local least squares (R3/2) on every mixed brick of a volume (at most MAXB): bytes against version 8."""
import sys, os, time, pickle, numpy as np
sys.path.insert(0, '/tmp/l19')
from volpack.volume_codec import predictfit
from localls import local_ls
MAXB = 3
for n in sys.argv[1].split(','):
    calls = pickle.load(open(f'/tmp/l19/{n}.pkl', 'rb'))[:MAXB]
    b8 = b9 = 0; vox = 0; dt = 0.0
    for c in calls:
        enc = lambda: len(predictfit.encode(c['values'], c['lo'], c['hi'], mask=c['mask'], fitted=c['fitted'], low=c['low'], tex=c['tex'], mix=True))
        b8 += enc()
        v = (c['values'] - c['lo']).astype(np.float64)
        t = time.process_time(); predictfit.LP = local_ls(v, 3, 2, 1e-3, 40); dt += time.process_time() - t
        b9 += enc(); predictfit.LP = None; vox += v.size
    print(f"{n:16s} {len(calls)} bricks {vox} voxels: v8 {b8} -> local LS {b9} ({100*(b8/b9-1):+.2f} %), {1e6*dt/vox:.1f} us/voxel", flush=True)
