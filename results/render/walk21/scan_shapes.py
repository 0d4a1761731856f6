"""CPU of the chunk scans a walk of an octree builds before its first frame: every
child-block shape of every level (what ``render.rehearse`` and the coarse level build),
the coefficient scan (``sigmap.scan``) and its arith context table, each shape once, in
one thread, after a warm-up call (kernels loaded). Run with PYTHONPATH=<tree>:

    PYTHONPATH=/work/main python results/render/walk21/scan_shapes.py /work/lead/walk/o.vpk
"""

import sys
import time

from volpack.entropy.arith import context_table
from volpack.octree import Octree, layout
from volpack.wavelet import sigmap

with Octree(sys.argv[1]) as tree:
    g, k2 = tree.geometry, 2 * tree.plan.block
    shapes = set()
    for level in range(1, tree.depth + 1):
        n = g.level_shape(level - 1)
        sides = [{min(k2, v)} | ({v % k2} if v % k2 else set()) for v in n]
        shapes |= {(a, b, c) for a in sides[0] for b in sides[1] for c in sides[2]}
context_table(sigmap.scan((4, 4, 4), (1, 1, 1), "dfs"))
best = None
for _ in range(5):
    sigmap.scan.cache_clear()
    t0 = time.perf_counter()
    scan_s = table_s = 0.0
    for s in sorted(shapes):
        a = time.perf_counter()
        sc = sigmap.scan(s, layout.lift_levels(s), tree.plan.order)
        b = time.perf_counter()
        context_table(sc)
        scan_s += b - a
        table_s += time.perf_counter() - b
    run = (time.perf_counter() - t0, scan_s, table_s)
    best = run if best is None or run[0] < best[0] else best
print(f"{len(shapes)} shapes: {1000 * best[0]:.1f} ms (scans {1000 * best[1]:.1f}, context "
      f"tables {1000 * best[2]:.1f}), best of 5")
