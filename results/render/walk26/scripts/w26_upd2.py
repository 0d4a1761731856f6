"""The MRI walk's first-frame resident update, timed: python w26_upd2.py WORKERS
[--prefetch-first] [--piece N] [--switch S] (prefetch and writes wall/CPU ms).
--prefetch-first decodes the frame's chunks on one thread before the update (the
writes alone); --piece sets resident.PIECE; --switch sys.setswitchinterval."""
import argparse, sys, time
ap = argparse.ArgumentParser()
ap.add_argument("workers", type=int)
ap.add_argument("--prefetch-first", action="store_true")
ap.add_argument("--piece", type=int)
ap.add_argument("--switch", type=float)
args = ap.parse_args()
sys.argv = [sys.argv[0], "time"]
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
if args.prefetch_first:
    orig_pf(tree, set().union(*(tree.node_chunks(lv, b, 1 if lv else 0) for lv, b in sel)), 1)
if args.piece:
    R.PIECE = args.piece
if args.switch:
    sys.setswitchinterval(args.switch)
t, c = time.perf_counter(), time.process_time()
pv = atlas.dense(sel, fill, nonempty_range(lo, hi), args.workers)
tot = (time.perf_counter() - t, time.process_time() - c)
print("workers", args.workers, "fill", fill, " ".join(f"{k} wall {v[0]*1e3:.1f} cpu {v[1]*1e3:.1f}" for k, v in T.items()), f"total wall {tot[0]*1e3:.1f} cpu {tot[1]*1e3:.1f}")
