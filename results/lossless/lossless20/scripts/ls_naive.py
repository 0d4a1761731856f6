import numpy as np, time, sys
sys.path.insert(0,'/work/wt/lossless20')
from volpack.volume_codec import localfit as lf
from volpack.volume_codec.predictfit import FIT_OFFSETS
OFF=np.array(FIT_OFFSETS)
def naive(v):
    nz,ny,nx=v.shape; out=np.full(v.shape, lf.NONE, np.int64)
    def row(zz,yy,xx):
        return [v[zz-a,yy-b,xx-c] for a,b,c in OFF]+[1]
    for z in range(2,nz):
        for y in range(2,ny-1):
            for x in range(2,nx-1):
                X=[];T=[]
                for yy in range(max(2,y-lf.R), y+1):
                    for xx in range(max(2,x-lf.R), min(nx-2,x+lf.R)+1):
                        if yy==y and xx>=x: break
                        X.append(row(z,yy,xx)); T.append(v[z,yy,xx])
                if z>=3:
                    for yy in range(max(2,y-lf.RU), min(ny-2,y+lf.RU)+1):
                        for xx in range(max(2,x-lf.RU), min(nx-2,x+lf.RU)+1):
                            X.append(row(z-1,yy,xx)); T.append(v[z-1,yy,xx])
                if len(T)<lf.MIN_SAMPLES: continue
                X=np.array(X,float);T=np.array(T,float)
                A=X.T@X; b=X.T@T; A+=np.eye(17)*(lf.RIDGE*np.trace(A)/17+1e-9)
                w=np.linalg.solve(A,b); p=w@np.array(row(z,y,x),float)
                out[z,y,x]=np.floor(8*p+0.5)
    return out
rng=np.random.default_rng(1)
for shape in [(5,9,11),(6,12,8),(4,6,30)]:
    base=np.add.outer(np.add.outer(np.arange(shape[0])*3, np.arange(shape[1])*2), np.arange(shape[2])).astype(np.int64)
    v=base+rng.integers(0,20,shape)
    a=lf.estimates(v,FIT_OFFSETS); b=naive(v)
    same=(a==lf.NONE)==(b==lf.NONE); d=np.abs(a-b)[(a!=lf.NONE)&(b!=lf.NONE)]
    print(shape, 'none-agree', same.all(), 'n', (a!=lf.NONE).sum(), (b!=lf.NONE).sum(), 'maxdiff', d.max() if d.size else None)
import gzip
v=np.load(gzip.open('/work/main/volpack/data/brainsmall.npy.gz')).astype(np.int64)
t=time.perf_counter(); e=lf.estimates(v,FIT_OFFSETS); t1=time.perf_counter()-t
t=time.perf_counter(); e=lf.estimates(v,FIT_OFFSETS); t2=time.perf_counter()-t
print('brainsmall', v.shape, 'first %.2f s, again %.2f s = %.2f us/voxel'%(t1,t2,1e6*t2/v.size))
sub=v[10:16,40:60,40:70]; a=lf.estimates(sub,FIT_OFFSETS); b=naive(sub); m=(a!=lf.NONE)&(b!=lf.NONE)
print('brain sub agree none',((a==lf.NONE)==(b==lf.NONE)).all(),'maxdiff',np.abs(a-b)[m].max(), 'mean |e|/8', np.abs(a[m]/8-sub[m]).mean())
