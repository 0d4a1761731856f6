import time, numpy as np
from volpack.octree import reader
t = reader.Octree("/work/cache/walk15/ct_head.vpk")
orig = reader.Octree._lift_up_fused
t._lift_up_fused = lambda *a: None
c0 = time.process_time(); t.decode(t.depth - 1); c1 = time.process_time()
print("step-by-step path, first decode (compiles its kernels): %.1f s" % (c1 - c0))
t2 = reader.Octree("/work/cache/walk15/ct_head.vpk")
c0 = time.process_time(); t2.decode(t2.depth - 1); c1 = time.process_time()
print("fused path, first decode (compiles chunk kernels): %.1f s" % (c1 - c0))
from volpack.octree import resample
c0 = time.process_time()
resample.axis_weights(0, 10, 2, 5); resample.put_clipped(np.zeros((2,2,2), np.int32), 0, 255, np.zeros((2,2,2), np.uint8))
print("axis_weights + put_clipped (uint8): %.1f s" % (time.process_time() - c0))
