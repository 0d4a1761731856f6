import sys, numpy as np, pickle
sys.path.insert(0,'scripts'); import datasets
def offs(R, RZ):
    o=[]
    for dz in range(0,RZ+1):
        for dy in range(-R,R+1):
            for dx in range(-R,R+1):
                if dz==0 and (dy<0 or (dy==0 and dx<=0)): continue
                if dz==0 and dy==0 and dx<=0: continue
                o.append((dz,dy,dx))
    # causal: (dz>0) or (dz==0, dy>0) or (dz==0,dy==0,dx>0) where offsets are steps back
    return [t for t in o if t[0]>0 or t[1]>0 or (t[1]==0 and t[2]>0)]
def study(a, sets):
    a=a.astype(np.float64); nz,ny,nx=a.shape
    m=3
    for name, o in sets:
        X=np.stack([a[m-dz:nz-dz, m-dy:ny-m-dy, m-dx:nx-m-dx].ravel() for dz,dy,dx in o],1)
        y=a[m:, m:ny-m, m:nx-m].ravel()
        X1=np.c_[X, np.ones(len(y))]
        w,*_=np.linalg.lstsq(X1,y,rcond=None); r=y-X1@w
        # entropy proxy: laplace with global scale per 2D local? use empirical entropy of rounded residual
        ri=np.round(r).astype(np.int64); h=np.bincount(ri-ri.min()); p=h[h>0]/len(ri)
        print(f"  {name:10s} n={len(o):3d} MAE {np.abs(r).mean():8.2f} H0(res) {-(p*np.log2(p)).sum():.3f}")
from volpack.volume_codec.predictfit import FIT_OFFSETS
for n in sys.argv[1:]:
    a=datasets.load(n)[0]; print(n)
    study(a, [('fit16', list(FIT_OFFSETS)), ('2d-r2', [t for t in offs(2,0)]), ('r2z1', offs(2,1)), ('r2z2', offs(2,2)), ('r3z1', offs(3,1)), ('r1z1',offs(1,1))])
