import sys, time, numpy as np
sys.path.insert(0,'/work/main/scripts')
import datasets
from volpack import api
for spec in sys.argv[1:]:
    name, rel = spec.split(':'); rel=float(rel)
    a=np.asarray(datasets.load(name)[0])
    b={e: api.compress_array(a, rel_error=rel, effort=e) for e in ('default','max')}
    for e in b: api.decompress_array(b[e])
    best={e:1e9 for e in b}
    for _ in range(3):
        for e in b:
            t=time.process_time(); api.decompress_array(b[e]); best[e]=min(best[e], time.process_time()-t)
    print(spec, {e:(len(b[e]), '%.3f s'%best[e]) for e in b}, 'max/default time x%.2f'%(best['max']/best['default']), flush=True)
