import numpy as np, time, sys, gzip, numba
sys.path.insert(0,'/work/wt/lossless20')
from volpack.volume_codec import localfit as new, _lf_old as old
from volpack.volume_codec.predictfit import FIT_OFFSETS
def mk(lf):
    @numba.njit
    def acc_only(v, shape, st, cs, ws, a, g, out):
        nz, ny, nx = shape[0], shape[1], shape[2]
        for z in range(2, nz):
            for y in range(ny):
                lf.row_start(cs, v, z, y, ny, nx, st, g)
                if y < 2 or y > ny - 2:
                    continue
                for x in range(2, nx - 1):
                    i = (z * ny + y) * nx + x
                    lf.advance(cs, ws, v, i, x, nx, st, g)
    return acc_only
v=np.load(gzip.open('/work/main/volpack/data/brainsmall.npy.gz')).astype(np.int64)
out=np.zeros(v.size,np.int64)
fs={}
for name,lf in (('old',old),('new',new)):
    f=mk(lf); args=(v.reshape(-1), np.array(v.shape), lf.steps(FIT_OFFSETS,v.shape), *lf.workspace(v.shape), out); f(*args); fs[name]=(f,args)
best={k:1e9 for k in fs}
for r in range(5):
    for k,(f,args) in fs.items():
        t=time.process_time(); f(*args); best[k]=min(best[k], time.process_time()-t)
print({k:'%.3f us/voxel'%(1e6*b/v.size) for k,b in best.items()})
