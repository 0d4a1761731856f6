import numpy as np, time, sys, os
sys.path.insert(0,'/work/wt/lossless20'); sys.path.insert(0,'/work/wt/lossless20/scripts')
import datasets
from volpack.volume_codec import predictfit as pf, localfit as lf
out=[]
for name in sys.argv[1].split(','):
    v=np.asarray(datasets.load(name)[0]).astype(np.int64)
    if v.ndim!=3: v=v.reshape(v.shape[-3:])
    # one brick, as bench bricks: the first 64^3 (or whole) region
    c=[max(0,(n-m)//2) for n,m in zip(v.shape,(64,128,128))]
    v=v[c[0]:c[0]+64,c[1]:c[1]+128,c[2]:c[2]+128]
    lo,hi=int(v.min()),int(v.max()); fits=pf.fit(v-lo)
    b8=len(pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True))
    t=time.perf_counter(); e=lf.estimates(v-lo,pf.FIT_OFFSETS); dt=time.perf_counter()-t
    b9=len(pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True,local=True))
    out.append(f"{name} {100*(1-b9/b8):+.2f}% ({1e6*dt/v.size:.2f}us)")
print(os.environ.get('VP_LS_K'), os.environ.get('VP_LS_R'), os.environ.get('VP_LS_RU'), ' | '.join(out), flush=True)
