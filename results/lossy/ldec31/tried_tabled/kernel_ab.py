import sys, time
sys.path.insert(0, 'results/lossy/ldec31')
import numpy as np, cells
from volpack import api
from volpack.entropy import arith
cap = []
orig = arith.decode
def dec(data, scan, out):
    cap.append((bytes(data), scan, out.shape, out.dtype)); return orig(data, scan, out)
arith.decode = dec
for spec in sys.argv[1:]:
    cap.clear()
    name, rel = spec.split(':')
    api.decompress_array(cells.blob(name, float(rel)))
    for data, s, shape, dt in cap:
        buf = np.frombuffer(data, np.uint8)
        n = s.perm.size
        def a():
            f = np.zeros(n, np.int64); return arith.decode_kernel(buf, s.perm, s.end, s.parent, s.cls, s.nbr, f, 63), f
        def b():
            t = arith.context_table(s); f = np.zeros(n, np.int64); return arith.decode_tabled_kernel(buf, s.perm, t, s.cls, f, 63), f
        ra, fa = a(); rb, fb = b(); tab = arith.context_table(s)
        def c():
            f = np.zeros(n, np.int64); return arith.decode_tabled_kernel(buf, s.perm, tab, s.cls, f, 63)
        ta = tb = tc = 1e9
        for _ in range(5):
            for f_, k in ((a, 'a'), (b, 'b'), (c, 'c')):
                t0 = time.process_time(); f_(); d = time.process_time() - t0
                if k == 'a': ta = min(ta, d)
                elif k == 'b': tb = min(tb, d)
                else: tc = min(tc, d)
        print(spec, n, ra == rb, np.array_equal(fa, fb), f"plain {1e3*ta:.2f} tabled+table {1e3*tb:.2f} tabled alone {1e3*tc:.2f} ms")
