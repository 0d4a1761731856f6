import cProfile, pstats, time, sys
import numpy as np
from volpack.octree import Octree, select
from volpack.render.lod import coarse_level, tree_range, NodeAtlas
from volpack.render.camera import Camera
from volpack.render.resident import ResidentVolume
from volpack.render.autotf import transfer_for
from volpack.render.framing import fit_camera
from volpack.render.raycast import TABLE_SIZE, empty_value, transfer_table
from volpack.render.transfer import nonempty_range
tree = Octree('/work/lead/walk/o.vpk', cache_bytes=1<<30)
sample, factor = coarse_level(tree)
lo, hi = tree_range(tree)
tf = transfer_for(None, sample.data, lo=lo, hi=hi, dtype=tree.dtype, mask=sample.mask, size=max(tree.shape))
view = fit_camera(Camera(size=(512,512)), sample.data, tf, lo, hi, spacing=tree.spacing, shape=tree.shape, factor=factor, mask=sample.mask, azimuths=[60.0*k for k in range(6)])
atlas = NodeAtlas(tree, gradients=True)
l2, h2 = nonempty_range(lo, hi)
fill = empty_value(transfer_table(tf, l2, h2, TABLE_SIZE), l2, h2, l2, quiet=True)
sel, st = select.by_view(tree, view, tf=tf, voxels=1024*4096, memo=atlas.select_memo, border=ResidentVolume.border)
mode = sys.argv[1]
if mode == "prof":
    pr = cProfile.Profile(); pr.enable()
t = time.perf_counter()
pv = atlas.dense(sel, fill, nonempty_range(lo, hi), 2)
print("update %.1f ms" % ((time.perf_counter() - t) * 1e3), file=sys.stderr)
if mode == "prof":
    pr.disable()
    pstats.Stats(pr).sort_stats("cumtime").print_stats(30)
