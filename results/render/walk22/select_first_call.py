import time, sys, cProfile, pstats
from volpack.octree import Octree, select
from volpack.render.lod import coarse_level, tree_range
from volpack.render.autotf import transfer_for
from volpack.render.camera import Camera
from volpack.render.framing import fit_camera
from volpack.render.resident import ResidentVolume
import volpack.render.raycast
with Octree('/work/lead/walk/o.vpk') as t:
    s, f = coarse_level(t); lo, hi = tree_range(t)
    tf = transfer_for(None, s.data, lo=lo, hi=hi, dtype=t.dtype, mask=s.mask, size=max(t.shape))
    view = Camera(azimuth=30, elevation=20.0, zoom=1.0, size=(512,512))
    view = fit_camera(view, s.data, tf, lo, hi, spacing=t.spacing, shape=t.shape, factor=f, mask=s.mask, azimuths=[60.0*k for k in range(6)])
    mods = set(sys.modules)
    p = cProfile.Profile()
    if len(sys.argv) > 1: p.enable()
    t0 = time.perf_counter()
    select.by_view(t, view, tf=tf, voxels=1024*16**3, memo={}, border=ResidentVolume.border)
    d = time.perf_counter() - t0
    p.disable()
    t0 = time.perf_counter()
    select.by_view(t, view, tf=tf, voxels=1024*16**3, memo={}, border=ResidentVolume.border)
    print(f"first {1e3*d:.1f} ms, second {1e3*(time.perf_counter()-t0):.1f} ms; new modules {sorted(set(sys.modules)-mods)}")
    if len(sys.argv) > 1: pstats.Stats(p).sort_stats('tottime').print_stats(12)
