import sys, pickle, numpy as np
from volpack.octree import Octree, select
from volpack.render.lod import coarse_level, tree_range
from volpack.render.autotf import transfer_for
from volpack.render.camera import Camera
from volpack.render.resident import ResidentVolume
from volpack.render.transfer import TransferFunction
out = []
with Octree('/work/lead/walk/o.vpk') as t:
    s, f = coarse_level(t); lo, hi = tree_range(t)
    tfs = [transfer_for(None, s.data, lo=lo, hi=hi, dtype=t.dtype, mask=s.mask, size=max(t.shape)),
           TransferFunction(((0.0, 0, 0, 0, 0.0), (40.0, 0.2, 0.1, 0.0, 0.0), (60.0, 1, 0.8, 0.6, 0.3), (130.0, 1, 1, 1, 0.9)))]
    for tf in tfs:
        memo = {}
        for az in (0, 33, 90, 200):
            for el, zoom, proj, dist in ((20, 1.0, "orthographic", None), (-40, 2.5, "orthographic", None), (10, 1.0, "perspective", 400.0), (0, 1.0, "perspective", 60.0)):
                cam = Camera(azimuth=az, elevation=el, zoom=zoom, size=(512, 384), projection=proj, distance=dist)
                for blocks, dec in ((1024, None), (256, None), (1024, 64)):
                    sel, st = select.by_view(t, cam, tf=tf, voxels=blocks * 16**3, memo=memo, decode=dec, border=ResidentVolume.border)
                    out.append((sel, st))
pickle.dump(out, open(sys.argv[1], "wb"))
print(len(out), sum(len(s) for s, _ in out))
