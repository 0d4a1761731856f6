import time, sys, numpy as np
t=time.process_time()
from volpack.volume_codec import predictfit as pf
v=(np.indices((6,9,9)).sum(0)*3).astype(np.int64)
kw=dict(mix=True)
if sys.argv[1]=='9': kw['local']=True
b=pf.encode(v,0,int(v.max()),**kw); t1=time.process_time()
pf.decode(b,v.shape,0,int(v.max()),**kw); t2=time.process_time()
print(sys.argv[1], 'encode+import %.1f CPU s, decode compile %.1f CPU s'%(t1-t, t2-t1))
