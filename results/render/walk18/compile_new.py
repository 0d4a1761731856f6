"""CPU seconds numba spends compiling walk18's new kernels, in a fresh kernel cache:
``_invisible_kernel`` (one signature) and ``_int_brick_range_kernel`` for the read-only
uint8 and int16 volumes the fast tests render.

    VOLPACK_CACHE_DIR=$(mktemp -d) PYTHONPATH=<walk18 tree> python compile_new.py
"""

import numpy as np

from volpack import jitwatch
from volpack.render import raycast as rc

took = []
jitwatch.subscribe(lambda ev, name, s: took.append((name, s)) if ev == "end" else None)
rc._invisible_kernel(np.zeros(3, np.float32), np.zeros(3, np.float32), 0.0, 1.0, 4,
                     np.zeros(5, np.int64), True, np.zeros((5, 5), np.int64), True,
                     np.zeros(3, np.bool_))  # fmt: skip
for dt in (np.uint8, np.int16):
    rc.brick_ranges(np.zeros((9, 9, 9), dt), 4, np.empty((3, 3, 3), np.float32),
                    np.empty((3, 3, 3), np.float32))  # fmt: skip
for name, s in took:
    print(f"{name}: {s:.2f} CPU s (its callees included)")

# what the fast tests no longer compile: the voxel-by-voxel kernel for those integer volumes
took.clear()
for dt in (np.uint8, np.int16):
    rc._brick_range_kernel(rc.read_only(np.zeros((9, 9, 9), dt)), 4, 0, 3,
                           np.empty((3, 3, 3), np.float32), np.empty((3, 3, 3), np.float32))  # fmt: skip
print("no longer compiled: " + ", ".join(f"{n} {s:.2f} CPU s" for n, s in took if n == "_brick_range_kernel"))
