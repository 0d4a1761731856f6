import numpy as np, time, sys, gzip
sys.path.insert(0,'/work/wt/lossless20')
from volpack.volume_codec import predictfit as pf, localfit as lf
v=np.load(gzip.open('/work/main/volpack/data/brainsmall.npy.gz')).astype(np.int64)
lo,hi=int(v.min()),int(v.max())
e=lf.estimates(v,pf.FIT_OFFSETS)
t=time.perf_counter(); e=lf.estimates(v,pf.FIT_OFFSETS); dt=time.perf_counter()-t
print('estimates %.3f us/voxel, none share %.3f'%(1e6*dt/v.size, (e==lf.NONE).mean()))
fits=pf.fit(v-lo)
b=pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True,local=True)
d=pf.decode(b,v.shape,lo,hi,tex=True,mix=True,local=True)
t=time.perf_counter(); d=pf.decode(b,v.shape,lo,hi,tex=True,mix=True,local=True); dt=time.perf_counter()-t
b8=pf.encode(v,lo,hi,fitted=fits[0],tex=True,mix=True)
t=time.perf_counter(); d8=pf.decode(b8,v.shape,lo,hi,tex=True,mix=True); dt8=time.perf_counter()-t
print('v9', len(b), 'v8', len(b8), 'saved %.2f %%'%(100*(1-len(b)/len(b8))), 'ok', np.array_equal(d,v), 'decode %.3f vs %.3f s (x%.2f)'%(dt,dt8,dt/dt8))
