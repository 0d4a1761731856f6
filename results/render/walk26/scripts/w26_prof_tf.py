import cProfile, pstats, time, sys
import numpy as np
from volpack.octree import Octree
from volpack.render.lod import coarse_level, tree_range, NodeAtlas
from volpack.render.camera import Camera
from volpack.render import raycast
tree = Octree('/work/lead/walk/o.vpk', cache_bytes=1<<30)
sample, factor = coarse_level(tree)
lo, hi = tree_range(tree)
from volpack.render.autotf import transfer_for
from volpack.render.framing import fit_camera
pr = cProfile.Profile()
t0 = time.perf_counter()
pr.enable()
tf = transfer_for(None, sample.data, lo=lo, hi=hi, dtype=tree.dtype, mask=sample.mask, size=max(tree.shape))
t1 = time.perf_counter()
view = Camera(size=(512,512))
view = fit_camera(view, sample.data, tf, lo, hi, spacing=tree.spacing, shape=tree.shape, factor=factor, mask=sample.mask, azimuths=[60.0*k for k in range(6)])
t2 = time.perf_counter()
from volpack.octree import select
sel, st = select.by_view(tree, view, tf=tf, voxels=1024*4096, memo={}, border=lambda lv: 1 if lv else 0)
t3 = time.perf_counter()
pr.disable()
print("tf %.1f fit %.1f select %.1f ms" % ((t1-t0)*1e3, (t2-t1)*1e3, (t3-t2)*1e3), file=sys.stderr)
pstats.Stats(pr).sort_stats("tottime").print_stats(25)
