import numpy as np, sys, os, numba
sys.path.insert(0,'/work/wt/lossless20'); sys.path.insert(0,'/work/wt/lossless20/scripts')
import datasets
from volpack.volume_codec import predictfit as pf, localfit as lf
NF,NG,NQ=lf.NF,lf.NG,lf.NQ
EVERY=int(os.environ.get('EVERY','2'))
@numba.njit
def solve_w(ws, a, w):
    n=ws[lf.N_AT]
    if n < lf.MIN_SAMPLES or n*ws[lf.TT_AT]==ws[lf.T_AT]*ws[lf.T_AT]: return False
    A=np.zeros((NF,NF)); b=np.zeros(NF); q=0
    for j in range(NF):
        for k in range(j,NF):
            A[j,k]=ws[q]; A[k,j]=ws[q]; q+=1
        b[j]=ws[q]; q+=1
    tr=0.0
    for j in range(NF): tr+=A[j,j]
    for j in range(NF): A[j,j]+=lf.RIDGE*tr/NF+1e-9
    w[:]=np.linalg.solve(A,b)
    return True
@numba.njit
def est_reuse(v, shape, st, cs, ws, a, g, out, every):
    nz, ny, nx = shape[0], shape[1], shape[2]
    w=np.zeros(NF); ok=False
    for z in range(2, nz):
        for y in range(ny):
            lf.row_start(cs, v, z, y, ny, nx, st, g)
            if y < 2 or y > ny - 2: continue
            for x in range(2, nx - 1):
                i = (z * ny + y) * nx + x
                lf.advance(cs, ws, v, i, x, nx, st, g)
                if (x - 2) % every == 0 or not ok:
                    ok = solve_w(ws, a, w)
                if ok:
                    p=w[NF-1]
                    for k in range(NF-1): p+=w[k]*v[i-st[k]]
                    out[i]=np.int64(np.floor(8*p+0.5))
                else:
                    out[i]=lf.NONE
def estimates(vv, offsets):
    v=np.ascontiguousarray(vv,np.int64); out=np.full(v.size, lf.NONE, np.int64)
    est_reuse(v.reshape(-1), np.array(v.shape), lf.steps(offsets, v.shape), *lf.workspace(v.shape), out, EVERY)
    return out.reshape(v.shape)
lf.estimates=estimates
res=[]
for name in sys.argv[1].split(','):
    v=np.asarray(datasets.load(name)[0]).astype(np.int64)
    c=[max(0,(n-m)//2) for n,m in zip(v.shape,(64,128,128))]
    v=v[c[0]:c[0]+64,c[1]:c[1]+128,c[2]:c[2]+128]
    lo,hi=int(v.min()),int(v.max()); fits=pf.fit(v-lo)
    b8=len(pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True))
    b9=len(pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True,local=True))
    res.append(f"{name} {100*(1-b9/b8):+.2f}%")
print('every',EVERY,' | '.join(res))
