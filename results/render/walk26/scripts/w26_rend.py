import time, sys
exec(open('/tmp/w26_prof_upd.py').read().split("mode = sys.argv[1]")[0])
from volpack.render.raycast import render
from volpack.render.prepared import PreparedVolume
pv = atlas.dense(sel, fill, nonempty_range(lo, hi), 2)
opts = dict(step=0.5, shading="phong", workers=2)
best = []
for i in range(6):
    p = PreparedVolume(pv.data, pv.spacing, None, nonempty_range(lo, hi))
    t, c = time.perf_counter(), time.process_time()
    img = render(p, tf=tf, camera=view, value_range=(lo, hi), **opts)
    best.append((time.perf_counter() - t, time.process_time() - c))
w = sorted(best)[:3]
print(sys.argv[1], "render wall best/med %.1f %.1f ms cpu %.1f" % (w[0][0]*1e3, w[1][0]*1e3, w[0][1]*1e3), float(img.sum()))
