import sys, time, numpy as np
import volpack.render.raycast as rc
rng = np.random.default_rng(5)
masks = []
for shape in [(1, 1, 1), (1, 5, 9), (7, 1, 3), (13, 17, 11), (40, 33, 29), (76, 93, 79)]:
    for fill in (0.0, 0.2, 0.6, 0.97, 1.0):
        masks.append(rng.random(shape) < fill)
    z, y, x = np.indices(shape)
    masks.append(((z - shape[0] / 2) ** 2 + (y - shape[1] / 3) ** 2 + (x - shape[2] / 2) ** 2) > (min(shape) / 3) ** 2)
outs = []
for m in masks:
    o = np.zeros(m.shape, np.int32); rc._leap_kernel(np.ascontiguousarray(m), o); outs.append(o)
m = masks[-1] | (rng.random(masks[-1].shape) < 0.5)
ts = []
for _ in range(15):
    o = np.zeros(m.shape, np.int32); t = time.thread_time(); rc._leap_kernel(m, o); ts.append(time.thread_time() - t)
print("leap map of 76x93x79 bricks: least %.1f ms, median %.1f ms CPU" % (1e3 * min(ts), 1e3 * sorted(ts)[7]))
np.savez_compressed(sys.argv[1], *outs)
