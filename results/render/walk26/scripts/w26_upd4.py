import time, sys
exec(open('/tmp/w26_prof_upd.py').read().split("mode = sys.argv[1]")[0])
import volpack.render.resident as R
from volpack.octree.reader import Octree as O
orig_pf, orig_cm = O.prefetch, R.completed_map
T = {}
def wrap(name, fn):
    def w(*a, **k):
        t, c = time.perf_counter(), time.process_time()
        r = fn(*a, **k)
        if name == "writes":
            r = list(r)
        T[name] = (time.perf_counter() - t, time.process_time() - c)
        return r
    return w
O.prefetch = wrap("prefetch", orig_pf)
R.completed_map = wrap("writes", orig_cm)
tree.prefetch(set().union(*(tree.node_chunks(lv, b, 1 if lv else 0) for lv, b in sel)), 1)
t, c = time.perf_counter(), time.process_time()
import volpack.render.resident as RR; RR.PIECE = int(sys.argv[2])
pv = atlas.dense(sel, fill, nonempty_range(lo, hi), int(sys.argv[1]))
tot = (time.perf_counter() - t, time.process_time() - c)
print("workers", sys.argv[1], "fill", fill, " ".join(f"{k} wall {v[0]*1e3:.1f} cpu {v[1]*1e3:.1f}" for k, v in T.items()), f"total wall {tot[0]*1e3:.1f} cpu {tot[1]*1e3:.1f}")
