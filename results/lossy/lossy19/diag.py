"""Per brick of a cell: the bounded encoder's candidates (tier, flag byte, bytes) and the
long fit's variants (reach, header bytes, residual by wavelet / predictive tool)."""
import sys, time
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import datasets
from volpack import api
from volpack.volume_codec import lossy, bounded_longfit as lf

seen, qs = [], []
keep0 = lossy.keep_faster
def keep(c):
    seen.append([(t, m[0][0], len(m[0])) for t, m in c])
    return keep0(c)
lossy.keep_faster = keep
long0 = lossy.BoundedCodec._longfit
def longfit(self, q, best):
    qs.append((self, q.copy(), best))
    return long0(self, q, best)
lossy.BoundedCodec._longfit = longfit

for name, rel in [a.split(":") for a in sys.argv[1].split(",")]:
    a = datasets.load(name)[0]
    e = float(rel) * float(a.max() - a.min())
    seen.clear(); qs.clear()
    t = time.time()
    blob = api.compress_array(a, max_error=e)
    print(f"{name} {rel} shape {a.shape} total {len(blob)} ({time.time()-t:.1f}s)")
    for s in seen:
        print("   cands", s)
    for codec, q, best in qs:
        qmax = int(np.iinfo(q.dtype).max)
        ranked = lf.rank_reaches(np.ascontiguousarray(q, np.int64))
        print(f"   brick {q.shape} best {best} ranked {ranked[:4]}")
        for reach in ranked[:3]:
            r, plan, w = lf.residuals(q, reach, qmax)
            head, res = lf.encode_head(r, plan, w)
            wav = len(codec._inner().encode(res))
            pre = len(codec._predictive().encode(res))
            nw = sum(len(x) for x in w if x is not None)
            print(f"     reach {reach} H0 {lf.estimate_bits(r)/8:.0f} head {len(head)} "
                  f"({nw} weights, {int(plan.present.sum())}/{len(w)} classes) wav {wav} pred {pre}")
