import sys, numpy as np
sys.path.insert(0,'scripts'); import datasets
from volpack.volume_codec.predictfit import FIT_OFFSETS
O=list(FIT_OFFSETS)
def feats(a,z,y,x): return np.array([a[z-dz,y-dy,x-dx] for dz,dy,dx in O]+[1.0])
for n,zs in (('mri_nibabel_t1',range(4,25,3)),('mri_dipy_s0',[3,5,7])):
    a=datasets.load(n)[0].astype(np.float64); nz,ny,nx=a.shape
    # global LS over interior
    rows=[(z,y,x) for z in range(2,nz) for y in range(2,ny-2) for x in range(2,nx-2)]
    X=np.array([feats(a,*t) for t in rows]); Y=np.array([a[t] for t in rows])
    w,*_=np.linalg.lstsq(X,Y,rcond=None)
    idx={t:i for i,t in enumerate(rows)}
    R=6
    for lam in (1e-3,):
        eg=[];el=[]
        for z in zs:
            for y in range(2+R,ny-2):
                for x in range(2+R,nx-2-R):
                    # causal training window: same slice rows above within R, slice before within R, and slice z-2
                    tr=[(zz,yy,xx) for zz in (z-1,z) for yy in range(y-R,y+1 if zz==z else y+R+1) for xx in range(x-R,x+R+1)
                        if (zz<z or yy<y) and (zz,yy,xx) in idx]
                    Xt=X[[idx[t] for t in tr]]; Yt=Y[[idx[t] for t in tr]]
                    A=Xt.T@Xt; A+=lam*np.trace(A)/17*np.eye(17)
                    wl=np.linalg.solve(A, Xt.T@Yt)
                    f=X[idx[(z,y,x)]]; v=a[z,y,x]
                    eg.append(v-f@w); el.append(v-f@wl)
        eg=np.abs(eg); el=np.abs(el)
        print(n, 'voxels', len(eg), 'MAE global', eg.mean().round(2), 'local', el.mean().round(2), 'min-of-two', np.minimum(eg,el).mean().round(2), 'avg', (np.abs(np.array(eg)*0+0)).mean() if 0 else '')
